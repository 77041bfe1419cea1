#!/usr/bin/env bash
# An SROS2 keystore made with plain openssl commands (no ROS install needed),
# in the layout `ros2 security create_keystore` / `create_enclave` write:
#
#   KEYSTORE/public/{identity_ca,permissions_ca}.cert.pem
#   KEYSTORE/private/{identity_ca,permissions_ca}.key.pem
#   KEYSTORE/enclaves/governance.{xml,p7s}
#   KEYSTORE/enclaves/ENCLAVE/{identity_ca.cert.pem, permissions_ca.cert.pem, governance.p7s,
#                              cert.pem, key.pem, permissions.xml, permissions.p7s}
#
# Unlike sros2's default (one CA for both roles) the identity CA, which signs
# the enclaves' certificates, and the permissions CA, which signs governance
# and permissions documents, are separate keys. Keys are ECDSA prime256v1 and
# unencrypted, as sros2 makes them (RustDDS verifies only ECDSA signatures on
# the documents and reads no encrypted keys).
#
# Usage:
#   make_keystore.sh create_keystore KEYSTORE
#   make_keystore.sh create_enclave KEYSTORE ENCLAVE [PUBLISH [SUBSCRIBE]]
# PUBLISH / SUBSCRIBE: space-separated DDS topic patterns the enclave may
# publish / subscribe (default "*": everything; ROS topic /job is DDS topic
# rt/job). The grant is for domain ROS_DOMAIN_ID (default 0) as sros2 does;
# DOMAINS="MIN-MAX" grants a range instead.
set -euo pipefail

die() { echo "make_keystore.sh: $*" >&2; exit 2; }
[ $# -ge 2 ] || die "usage: create_keystore KEYSTORE | create_enclave KEYSTORE ENCLAVE [PUBLISH [SUBSCRIBE]]"
command -v openssl >/dev/null || die "openssl is not installed"

# Runs a command, showing its output only when it fails.
quiet() {
  local out
  out=$("$@" 2>&1) || { echo "$out" >&2; die "failed: $*"; }
}

cmd=$1
ks=$2
days=3650

# An ECDSA P-256 private key in PKCS#8 PEM ("BEGIN PRIVATE KEY"), the form
# sros2 writes and RustDDS reads.
new_key() {
  quiet openssl genpkey -algorithm EC -pkeyopt ec_paramgen_curve:prime256v1 -out "$1"
  chmod 600 "$1"
}

# A self-signed CA: private/NAME.key.pem, public/NAME.cert.pem.
make_ca() {
  local name=$1
  new_key "$ks/private/$name.key.pem"
  quiet openssl req -x509 -new -key "$ks/private/$name.key.pem" -out "$ks/public/$name.cert.pem" \
    -days "$days" -sha256 -subj "/CN=sros2_${name}" \
    -addext "basicConstraints=critical,CA:true"
}

# S/MIME signature of XML by the permissions CA (text mode, as sros2 signs).
sign() {
  openssl smime -sign -text -in "$1" -out "$2" \
    -signer "$ks/public/permissions_ca.cert.pem" -inkey "$ks/private/permissions_ca.key.pem"
}

domains_xml() {
  if [ -n "${DOMAINS:-}" ]; then
    echo "<id_range><min>${DOMAINS%-*}</min><max>${DOMAINS#*-}</max></id_range>"
  else
    echo "<id>${ROS_DOMAIN_ID:-0}</id>"
  fi
}

topics_xml() {
  local t
  set -f # "*" is a topic pattern, not a file glob
  for t in $1; do echo "            <topic>$t</topic>"; done
}

case "$cmd" in
  create_keystore)
    [ ! -e "$ks/enclaves" ] || die "$ks already holds a keystore"
    mkdir -p "$ks/public" "$ks/private" "$ks/enclaves"
    chmod 700 "$ks/private"
    make_ca identity_ca
    make_ca permissions_ca
    # Only authenticated participants join, with join, read and write access
    # control on every topic; discovery, liveliness and every RTPS message
    # encrypted (AES-GCM keys exchanged with authenticated peers only).
    # sros2's default protects each topic's data and metadata instead
    # (rtps SIGN, metadata and data ENCRYPT): RustDDS 0.15 fails to decode
    # protected payloads and loses large samples with protected metadata
    # (docs/node.md, "DDS Security (SROS2)"). The *_PROTECTION variables
    # override the kinds, for trying other combinations.
    cat > "$ks/enclaves/governance.xml" <<XML
<?xml version="1.0" encoding="UTF-8"?>
<dds xmlns:xsi="http://www.w3.org/2001/XMLSchema-instance" xsi:noNamespaceSchemaLocation="http://www.omg.org/spec/DDS-Security/20170801/omg_shared_ca_governance.xsd">
  <domain_access_rules>
    <domain_rule>
      <domains>
        <id_range>
          <min>0</min>
          <max>231</max>
        </id_range>
      </domains>
      <allow_unauthenticated_participants>false</allow_unauthenticated_participants>
      <enable_join_access_control>true</enable_join_access_control>
      <discovery_protection_kind>${DISCOVERY_PROTECTION:-ENCRYPT}</discovery_protection_kind>
      <liveliness_protection_kind>${LIVELINESS_PROTECTION:-ENCRYPT}</liveliness_protection_kind>
      <rtps_protection_kind>${RTPS_PROTECTION:-ENCRYPT}</rtps_protection_kind>
      <topic_access_rules>
        <topic_rule>
          <topic_expression>*</topic_expression>
          <enable_discovery_protection>true</enable_discovery_protection>
          <enable_liveliness_protection>true</enable_liveliness_protection>
          <enable_read_access_control>true</enable_read_access_control>
          <enable_write_access_control>true</enable_write_access_control>
          <metadata_protection_kind>${METADATA_PROTECTION:-NONE}</metadata_protection_kind>
          <data_protection_kind>${DATA_PROTECTION:-NONE}</data_protection_kind>
        </topic_rule>
      </topic_access_rules>
    </domain_rule>
  </domain_access_rules>
</dds>
XML
    sign "$ks/enclaves/governance.xml" "$ks/enclaves/governance.p7s"
    ;;
  create_enclave)
    [ $# -ge 3 ] || die "create_enclave needs KEYSTORE ENCLAVE"
    enclave=$3
    publish=${4:-*}
    subscribe=${5:-*}
    case "$enclave" in /*) ;; *) die "the enclave path must be absolute (/name): $enclave" ;; esac
    [ -f "$ks/enclaves/governance.p7s" ] || die "$ks is not a keystore (run create_keystore first)"
    dir="$ks/enclaves${enclave}"
    mkdir -p "$dir"
    # The CA certificates and the governance are links into the keystore, as sros2 makes them.
    rel=$(realpath --relative-to="$dir" "$ks")
    ln -sf "$rel/public/identity_ca.cert.pem" "$dir/identity_ca.cert.pem"
    ln -sf "$rel/public/permissions_ca.cert.pem" "$dir/permissions_ca.cert.pem"
    ln -sf "$rel/enclaves/governance.p7s" "$dir/governance.p7s"
    # The enclave's identity: subject CN=ENCLAVE, signed by the identity CA.
    new_key "$dir/key.pem"
    # (openssl's -subj separates fields with "/": the enclave's are escaped.)
    quiet openssl req -new -key "$dir/key.pem" -subj "/CN=${enclave//\//\\/}" -out "$dir/req.pem"
    quiet openssl x509 -req -in "$dir/req.pem" -days "$days" -sha256 \
      -CA "$ks/public/identity_ca.cert.pem" -CAkey "$ks/private/identity_ca.key.pem" \
      -set_serial "0x$(openssl rand -hex 8)" -out "$dir/cert.pem"
    rm "$dir/req.pem"
    now=$(date -u +%Y-%m-%dT%H:%M:%S)
    until=$(date -u -d "+$days days" +%Y-%m-%dT%H:%M:%S)
    cat > "$dir/permissions.xml" <<XML
<?xml version="1.0" encoding="UTF-8"?>
<dds xmlns:xsi="http://www.w3.org/2001/XMLSchema-instance" xsi:noNamespaceSchemaLocation="http://www.omg.org/spec/DDS-Security/20170801/omg_shared_ca_permissions.xsd">
  <permissions>
    <grant name="$enclave">
      <subject_name>CN=$enclave</subject_name>
      <validity>
        <not_before>$now</not_before>
        <not_after>$until</not_after>
      </validity>
      <allow_rule>
        <domains>
          $(domains_xml)
        </domains>
        <publish>
          <topics>
$(topics_xml "$publish")
          </topics>
        </publish>
        <subscribe>
          <topics>
$(topics_xml "$subscribe")
          </topics>
        </subscribe>
      </allow_rule>
      <default>DENY</default>
    </grant>
  </permissions>
</dds>
XML
    sign "$dir/permissions.xml" "$dir/permissions.p7s"
    ;;
  *) die "unknown command \"$cmd\": create_keystore or create_enclave" ;;
esac
