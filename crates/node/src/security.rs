//! DDS Security for the node, with ROS 2's SROS2 conventions: the enclave
//! from `--ros-args --enclave PATH` (or `ROS_SECURITY_ENCLAVE_OVERRIDE`), the
//! keystore from `ROS_SECURITY_KEYSTORE`, security on only when
//! `ROS_SECURITY_ENABLE=true`, and `ROS_SECURITY_STRATEGY=Enforce` to refuse
//! to start without the enclave's files (any other strategy starts
//! unsecured with a warning when they are missing). The enclave's files are
//! `KEYSTORE/enclaves/PATH/{identity_ca.cert.pem, cert.pem, key.pem,
//! permissions_ca.cert.pem, governance.p7s, permissions.p7s}`, the names
//! rmw_dds_common gives them.
//!
//! Files that exist but do not verify (a document changed after signing, a
//! certificate from another CA) stop the node in every strategy: falling
//! back to an open node would hide the tampering. The DDS plugins are
//! RustDDS's builtin ones (`security` cargo feature); see docs/node.md,
//! "DDS Security (SROS2)".

use std::path::{Path, PathBuf};
use toolpath_kernel::error::{Error, Result};

/// The enclave's files, in the order they are checked.
pub const ENCLAVE_FILES: [&str; 6] = [
    IDENTITY_CA,
    CERT,
    KEY,
    PERMISSIONS_CA,
    GOVERNANCE,
    PERMISSIONS,
];
pub const IDENTITY_CA: &str = "identity_ca.cert.pem";
pub const CERT: &str = "cert.pem";
pub const KEY: &str = "key.pem";
pub const PERMISSIONS_CA: &str = "permissions_ca.cert.pem";
pub const GOVERNANCE: &str = "governance.p7s";
pub const PERMISSIONS: &str = "permissions.p7s";

/// `ROS_SECURITY_STRATEGY`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Strategy {
    /// Refuse to start without the enclave's files.
    Enforce,
    /// Start unsecured (with a warning) when they are missing.
    Permissive,
}

/// The security request of the environment and the `--ros-args` block.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Request {
    pub enabled: bool,
    pub strategy: Strategy,
    pub keystore: Option<PathBuf>,
    /// The enclave path (`/toolpath_planner`); rcl's default is `/`.
    pub enclave: String,
}

impl Request {
    /// From the environment variables read by `var` and the enclave of the
    /// `--ros-args` block (`ROS_SECURITY_ENCLAVE_OVERRIDE` wins, as in rcl).
    pub fn new(var: impl Fn(&str) -> Option<String>, enclave_arg: Option<&str>) -> Self {
        let nonempty = |k: &str| var(k).filter(|v| !v.is_empty());
        Request {
            enabled: nonempty("ROS_SECURITY_ENABLE").as_deref() == Some("true"),
            strategy: match nonempty("ROS_SECURITY_STRATEGY").as_deref() {
                Some("Enforce") => Strategy::Enforce,
                _ => Strategy::Permissive,
            },
            keystore: nonempty("ROS_SECURITY_KEYSTORE").map(PathBuf::from),
            enclave: nonempty("ROS_SECURITY_ENCLAVE_OVERRIDE")
                .or_else(|| enclave_arg.map(str::to_string))
                .unwrap_or_else(|| "/".to_string()),
        }
    }

    /// From this process's environment.
    pub fn from_env(enclave_arg: Option<&str>) -> Self {
        Self::new(|k| std::env::var(k).ok(), enclave_arg)
    }

    /// The enclave directory to secure the participant with, or `None` to
    /// run unsecured. Checks that the directory and its six files are
    /// there; a missing one is an error under Enforce and a warning (and no
    /// security) otherwise. Does not read the files: see [`verify`].
    pub fn enclave_dir(&self) -> Result<Option<PathBuf>> {
        if !self.enabled {
            return Ok(None);
        }
        if !self.enclave.starts_with('/') {
            return Err(Error::invalid(
                "--ros-args --enclave",
                format!(
                    "\"{}\" is not an enclave path: it must be absolute (/name)",
                    self.enclave
                ),
            ));
        }
        let missing = |field: String, why: String| -> Result<Option<PathBuf>> {
            match self.strategy {
                Strategy::Enforce => Err(Error::invalid(
                    field,
                    format!("{why} (ROS_SECURITY_STRATEGY=Enforce: the node does not start without DDS Security)"),
                )),
                Strategy::Permissive => {
                    log::warn!(
                        "DDS Security is off: {field}: {why} (set ROS_SECURITY_STRATEGY=Enforce to refuse to start instead)"
                    );
                    Ok(None)
                }
            }
        };
        let Some(keystore) = &self.keystore else {
            return missing(
                "ROS_SECURITY_KEYSTORE".into(),
                "is not set, and ROS_SECURITY_ENABLE=true asks for DDS Security".into(),
            );
        };
        let dir = keystore
            .join("enclaves")
            .join(self.enclave.trim_start_matches('/'));
        if !dir.is_dir() {
            return missing(
                format!("--ros-args --enclave {}", self.enclave),
                format!(
                    "the keystore has no such enclave: {} is not a directory",
                    dir.display()
                ),
            );
        }
        for f in ENCLAVE_FILES {
            let path = dir.join(f);
            // `is_file` follows links: sros2 links the CA certificates and the governance.
            if !path.is_file() {
                return missing(
                    path.display().to_string(),
                    "the enclave's file is missing (or not a regular file)".into(),
                );
            }
        }
        Ok(Some(dir))
    }
}

/// Checks the enclave's files with OpenSSL before DDS reads them, so that a
/// bad one is named: the governance and permissions documents must carry a
/// valid S/MIME signature of the permissions CA, the certificate must be
/// signed by the identity CA, within its validity, and match the key.
#[cfg(feature = "security")]
pub fn verify(dir: &Path) -> Result<()> {
    use openssl::asn1::Asn1Time;
    use openssl::pkcs7::{Pkcs7, Pkcs7Flags};
    use openssl::pkey::PKey;
    use openssl::stack::Stack;
    use openssl::x509::store::X509StoreBuilder;
    use openssl::x509::X509;

    let read = |f: &str| -> Result<(PathBuf, Vec<u8>)> {
        let p = dir.join(f);
        let bytes = std::fs::read(&p).map_err(|e| Error::io(p.display().to_string(), e))?;
        Ok((p, bytes))
    };
    let bad = |p: &Path, why: String| Error::invalid(p.display().to_string(), why);
    let cert_of = |f: &str| -> Result<X509> {
        let (p, pem) = read(f)?;
        X509::from_pem(&pem).map_err(|e| bad(&p, format!("not a PEM X.509 certificate: {e}")))
    };

    let permissions_ca = cert_of(PERMISSIONS_CA)?;
    for f in [GOVERNANCE, PERMISSIONS] {
        let (p, smime) = read(f)?;
        let (pkcs7, content) = Pkcs7::from_smime(&smime)
            .map_err(|e| bad(&p, format!("not an S/MIME signed document: {e}")))?;
        let mut store = X509StoreBuilder::new().map_err(|e| bad(&p, e.to_string()))?;
        store
            .add_cert(permissions_ca.clone())
            .map_err(|e| bad(&p, e.to_string()))?;
        let store = store.build();
        let none = Stack::<X509>::new().map_err(|e| bad(&p, e.to_string()))?;
        pkcs7
            .verify(&none, &store, content.as_deref(), None, Pkcs7Flags::empty())
            .map_err(|e| {
                bad(
                    &p,
                    format!(
                        "the signature does not verify against {PERMISSIONS_CA} (changed after signing, or signed by another CA): {e}"
                    ),
                )
            })?;
    }

    let identity_ca = cert_of(IDENTITY_CA)?;
    let cert = cert_of(CERT)?;
    let cert_path = dir.join(CERT);
    let ca_key = identity_ca
        .public_key()
        .map_err(|e| bad(&dir.join(IDENTITY_CA), e.to_string()))?;
    if !cert.verify(&ca_key).unwrap_or(false) {
        return Err(bad(
            &cert_path,
            format!("the certificate is not signed by {IDENTITY_CA}"),
        ));
    }
    let now = Asn1Time::days_from_now(0).map_err(|e| bad(&cert_path, e.to_string()))?;
    if cert.not_before() > now || cert.not_after() < now {
        return Err(bad(
            &cert_path,
            format!(
                "the certificate is not valid now (valid from {} to {})",
                cert.not_before(),
                cert.not_after()
            ),
        ));
    }
    let (key_path, key_pem) = read(KEY)?;
    let key = PKey::private_key_from_pem(&key_pem)
        .map_err(|e| bad(&key_path, format!("not a PEM private key: {e}")))?;
    let cert_key = cert
        .public_key()
        .map_err(|e| bad(&cert_path, e.to_string()))?;
    if !cert_key.public_eq(&key) {
        return Err(bad(&key_path, format!("the key does not belong to {CERT}")));
    }
    Ok(())
}

/// The RustDDS participant builder with the builtin security plugins
/// configured from `dir` (the enclave's files, checked by [`verify`]).
#[cfg(feature = "security")]
pub fn secure(
    builder: rustdds::DomainParticipantBuilder,
    dir: &Path,
) -> Result<rustdds::DomainParticipantBuilder> {
    verify(dir)?;
    let dir = dir
        .canonicalize()
        .map_err(|e| Error::io(dir.display().to_string(), e))?;
    Ok(builder.builtin_security(
        rustdds::DomainParticipantSecurityConfigFiles::with_ros_default_names(dir, String::new()),
    ))
}

/// Without the `security` feature there are no plugins: an enclave is
/// refused (the caller decides whether that stops the node).
#[cfg(not(feature = "security"))]
pub fn secure(
    _builder: rustdds::DomainParticipantBuilder,
    dir: &Path,
) -> Result<rustdds::DomainParticipantBuilder> {
    Err(Error::invalid(
        dir.display().to_string(),
        "this build of toolpath has no DDS Security: rebuild with `cargo build --features security`",
    ))
}

/// Whether this build has the DDS Security plugins.
pub const BUILT_WITH_SECURITY: bool = cfg!(feature = "security");

#[cfg(test)]
mod tests {
    use super::*;

    fn req(vars: &[(&str, &str)], enclave: Option<&str>) -> Request {
        let vars: Vec<(String, String)> = vars
            .iter()
            .map(|(k, v)| (k.to_string(), v.to_string()))
            .collect();
        Request::new(
            |k| vars.iter().find(|(n, _)| n == k).map(|(_, v)| v.clone()),
            enclave,
        )
    }

    #[test]
    fn security_is_off_unless_enabled_as_rcl_reads_it() {
        let r = req(&[("ROS_SECURITY_KEYSTORE", "/nowhere")], Some("/tp"));
        assert!(!r.enabled);
        assert_eq!(r.enclave_dir().unwrap(), None);
        // rcl compares with "true" exactly.
        let r = req(&[("ROS_SECURITY_ENABLE", "1")], None);
        assert!(!r.enabled);
        let r = req(
            &[
                ("ROS_SECURITY_ENABLE", "true"),
                ("ROS_SECURITY_ENCLAVE_OVERRIDE", "/other"),
            ],
            Some("/tp"),
        );
        assert!(r.enabled);
        assert_eq!(r.enclave, "/other");
        assert_eq!(r.strategy, Strategy::Permissive);
        assert_eq!(req(&[], None).enclave, "/");
    }

    #[test]
    fn missing_files_stop_the_node_under_enforce_only() {
        let ks = tempfile::tempdir().unwrap();
        let dir = ks.path().join("enclaves/cell/tp");
        std::fs::create_dir_all(&dir).unwrap();
        let ks_str = ks.path().to_str().unwrap();
        let enforce = |enclave: &str| {
            req(
                &[
                    ("ROS_SECURITY_ENABLE", "true"),
                    ("ROS_SECURITY_STRATEGY", "Enforce"),
                    ("ROS_SECURITY_KEYSTORE", ks_str),
                ],
                Some(enclave),
            )
        };
        let e = enforce("/cell/nope").enclave_dir().unwrap_err().to_string();
        assert!(
            e.contains("--enclave /cell/nope")
                && e.contains("enclaves/cell/nope is not a directory"),
            "{e}"
        );
        let e = enforce("/cell/tp").enclave_dir().unwrap_err().to_string();
        assert!(
            e.contains("enclaves/cell/tp/identity_ca.cert.pem") && e.contains("missing"),
            "{e}"
        );
        for f in ENCLAVE_FILES {
            std::fs::write(dir.join(f), "x").unwrap();
        }
        assert_eq!(
            enforce("/cell/tp").enclave_dir().unwrap(),
            Some(dir.clone())
        );
        std::fs::remove_file(dir.join(PERMISSIONS)).unwrap();
        let e = enforce("/cell/tp").enclave_dir().unwrap_err().to_string();
        assert!(e.contains("cell/tp/permissions.p7s"), "{e}");
        // Permissive: a warning and no security.
        let permissive = req(
            &[
                ("ROS_SECURITY_ENABLE", "true"),
                ("ROS_SECURITY_KEYSTORE", ks_str),
            ],
            Some("/cell/tp"),
        );
        assert_eq!(permissive.enclave_dir().unwrap(), None);
        let e = enforce("cell/tp").enclave_dir().unwrap_err().to_string();
        assert!(e.contains("must be absolute"), "{e}");
        let no_keystore = req(
            &[
                ("ROS_SECURITY_ENABLE", "true"),
                ("ROS_SECURITY_STRATEGY", "Enforce"),
            ],
            None,
        );
        let e = no_keystore.enclave_dir().unwrap_err().to_string();
        assert!(e.contains("ROS_SECURITY_KEYSTORE: is not set"), "{e}");
    }
}
