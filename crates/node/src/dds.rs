//! The DDS side every ROS 2 participant of this crate shares: a node on the
//! configured domain and interfaces (optionally secured), with topic names
//! resolved under its namespace and remapping. The node, its clients (tests,
//! `toolpath replay --publish`, the bench) and the fake controller use it.

use super::ros_args::Remaps;
use ros2_client::ros2::QosProfile;
use ros2_client::{
    Context, MessageTypeName, Name, Node, NodeName, NodeOptions, Publisher, Subscription,
};
use toolpath_kernel::error::{Error, Result};
use toolpath_messages::{topics, RosMessage};

/// Absolute ROS name of a relative topic in `namespace`.
pub fn topic_name(namespace: &str, relative: &str) -> Result<Name> {
    let full = topics::absolute(namespace, relative);
    Name::parse(&full).map_err(|e| {
        Error::invalid(
            "node.namespace",
            format!("topic name \"{full}\" is not valid: {e}"),
        )
    })
}

fn ros_err(what: &str, e: impl std::fmt::Debug) -> Error {
    Error::dds(format!("{what}: {e:?}"))
}

/// The IP addresses of this host's network interfaces.
fn host_addresses() -> Result<Vec<std::net::IpAddr>> {
    let addrs = nix::ifaddrs::getifaddrs()
        .map_err(|e| Error::system(format!("cannot list the network interfaces: {e}")))?;
    Ok(addrs
        .filter_map(|a| {
            let a = a.address?;
            if let Some(v4) = a.as_sockaddr_in() {
                Some(std::net::IpAddr::V4(v4.ip()))
            } else {
                a.as_sockaddr_in6().map(|v6| std::net::IpAddr::V6(v6.ip()))
            }
        })
        .collect())
}

/// Every configured interface address must belong to this host: DDS would
/// otherwise advertise an address nobody can reach it on (or none at all)
/// and the node would look ready while deaf.
pub fn check_on_this_host(ips: &[std::net::IpAddr]) -> Result<()> {
    let host = host_addresses()?;
    for (k, ip) in ips.iter().enumerate() {
        if !host.contains(ip) {
            let mut have: Vec<String> = host.iter().map(|a| a.to_string()).collect();
            have.sort();
            have.dedup();
            return Err(Error::invalid(
                format!("node.interfaces[{k}]"),
                format!(
                    "{ip} is not an address of this host (its addresses: {})",
                    have.join(", ")
                ),
            ));
        }
    }
    Ok(())
}

/// A ROS 2 context + node on the configured domain and interfaces, with the
/// spinner running (without it matching never completes).
pub struct RosNode {
    pub node: Node,
    pub namespace: String,
    /// Topic remapping rules (`--ros-args -r from:=to`).
    remaps: Remaps,
    /// The request/reply mapping of the services and actions it creates.
    pub service_mapping: ros2_client::ServiceMapping,
    _context: Context,
}

impl RosNode {
    pub fn new(
        name: &str,
        namespace: &str,
        domain_id: u16,
        interfaces: Option<Vec<std::net::IpAddr>>,
    ) -> Result<Self> {
        Self::secured(name, namespace, domain_id, interfaces, None)
    }

    /// [`RosNode::new`] with DDS Security from an SROS2 enclave directory
    /// (`None`: unsecured); see [`super::security`].
    pub fn secured(
        name: &str,
        namespace: &str,
        domain_id: u16,
        interfaces: Option<Vec<std::net::IpAddr>>,
        enclave_dir: Option<&std::path::Path>,
    ) -> Result<Self> {
        let options = NodeOptions::new().enable_rosout(false);
        Self::with_options(
            name,
            namespace,
            domain_id,
            interfaces,
            options,
            &[],
            enclave_dir,
        )
    }

    /// A node with `options` (parameters, rosout), topic `remaps` and DDS
    /// Security from `enclave_dir` when given.
    pub fn with_options(
        name: &str,
        namespace: &str,
        domain_id: u16,
        interfaces: Option<Vec<std::net::IpAddr>>,
        options: NodeOptions,
        remaps: &[(String, String)],
        enclave_dir: Option<&std::path::Path>,
    ) -> Result<Self> {
        let mut builder = rustdds::DomainParticipantBuilder::new(domain_id);
        if let Some(ips) = interfaces {
            check_on_this_host(&ips)?;
            builder = builder.with_only_networks(ips);
        }
        if let Some(dir) = enclave_dir {
            builder = super::security::secure(builder, dir)?;
        }
        let dp = builder.build().map_err(|e| match enclave_dir {
            Some(dir) => Error::invalid(
                dir.display().to_string(),
                format!("DDS Security refused the enclave's files: {e}"),
            ),
            None => ros_err("cannot create the DDS participant", e),
        })?;
        let context = Context::from_domain_participant(dp)
            .map_err(|e| ros_err("cannot create the context", e))?;
        let node_name = NodeName::new(namespace, name)
            .map_err(|e| Error::invalid("node.name", format!("\"{namespace}\" \"{name}\": {e}")))?;
        let mut node = context
            .new_node(node_name, options)
            .map_err(|e| ros_err("cannot create the node", e))?;
        let spinner = node
            .spinner()
            .map_err(|e| ros_err("cannot start the spinner", e))?;
        tokio::spawn(async move {
            if let Err(e) = spinner.spin().await {
                log::error!("ROS 2 spinner stopped: {e:?}");
            }
        });
        Ok(Self {
            node,
            namespace: namespace.to_string(),
            remaps: Remaps::new(remaps, namespace, name),
            service_mapping: ros2_client::ServiceMapping::Enhanced,
            _context: context,
        })
    }

    /// The fully qualified name of the node's topic `relative`, after remapping.
    pub fn resolved(&self, relative: &str) -> String {
        self.remaps
            .apply(&topics::absolute(&self.namespace, relative))
    }

    fn topic<M: RosMessage>(&mut self, relative: &str, qos: &QosProfile) -> Result<rustdds::Topic> {
        let name = topic_name(&self.namespace, relative)?;
        let name = match self.remaps.apply(&name.to_string()) {
            same if same == name.to_string() => name,
            remapped => Name::parse(&remapped).map_err(|e| {
                Error::invalid(
                    "--ros-args -r",
                    format!("topic {relative} remapped to \"{remapped}\", which is not a valid name: {e}"),
                )
            })?,
        };
        self.node
            .create_topic(&name, MessageTypeName::new(M::PACKAGE, M::NAME), qos)
            .map_err(|e| ros_err(&format!("cannot create topic {relative}"), e))
    }

    pub fn publisher<M: RosMessage>(
        &mut self,
        relative: &str,
        qos: QosProfile,
    ) -> Result<Publisher<M>> {
        let topic = self.topic::<M>(relative, &qos)?;
        self.node
            .create_publisher(&topic, Some(qos))
            .map_err(|e| ros_err(&format!("cannot publish on {relative}"), e))
    }

    pub fn subscription<M: RosMessage>(
        &mut self,
        relative: &str,
        qos: QosProfile,
    ) -> Result<Subscription<M>> {
        let topic = self.topic::<M>(relative, &qos)?;
        self.node
            .create_subscription(&topic, Some(qos))
            .map_err(|e| ros_err(&format!("cannot subscribe to {relative}"), e))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::net::{IpAddr, Ipv4Addr};

    #[test]
    fn an_interface_not_on_this_host_is_refused_by_name() {
        check_on_this_host(&[IpAddr::V4(Ipv4Addr::LOCALHOST)]).unwrap();
        // 192.0.2.0/24 is reserved for documentation (RFC 5737): never a host's address.
        let e = check_on_this_host(&[
            IpAddr::V4(Ipv4Addr::LOCALHOST),
            IpAddr::V4(Ipv4Addr::new(192, 0, 2, 7)),
        ])
        .unwrap_err()
        .to_string();
        assert!(
            e.contains("node.interfaces[1]")
                && e.contains("192.0.2.7 is not an address of this host")
                && e.contains("127.0.0.1"),
            "{e}"
        );
    }
}
