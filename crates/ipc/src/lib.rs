//! Zero-copy toolpath output over iceoryx2 for consumers on the same host
//! (a machine-controller bridge, a simulator) that cannot afford DDS
//! serialisation of very large paths.
//!
//! Service `toolpath_planner/toolpath`, publish-subscribe of a `[u8]` slice
//! (dynamic size, power-of-two reallocation) holding one toolpath: a
//! [`ToolpathHeader`] followed by `point_count` [`IpcPoint`]s, both
//! `#[repr(C)]` with fixed little-endian layouts documented in
//! docs/formats.md. The publisher writes the points straight into the loaned
//! shared-memory sample (no intermediate buffer); a subscriber reads them in
//! place. A byte slice (rather than a typed slice with a user header) keeps the
//! service type `u8`, which every language binding of iceoryx2 can open.

use iceoryx2::prelude::*;
use toolpath_formats::PlanResult;
use toolpath_kernel::error::{Error, Result};

/// The production service name.
pub const SERVICE_NAME: &str = "toolpath_planner/toolpath";

/// `magic` of every payload.
pub const MAGIC: [u8; 4] = *b"TPTH";
/// Payload layout version.
pub const VERSION: u32 = 1;

/// Payload header (256 bytes, little-endian, 8-byte aligned fields).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ToolpathHeader {
    /// b"TPTH".
    pub magic: [u8; 4],
    /// Layout version, 1.
    pub version: u32,
    /// size_of::<ToolpathHeader>() = 256: where the points start.
    pub header_size: u32,
    /// size_of::<IpcPoint>() = 112.
    pub point_size: u32,
    pub point_count: u64,
    pub pass_count: u64,
    /// Counts the toolpaths this publisher has sent, from 1.
    pub sequence: u64,
    pub path_length_mm: f64,
    pub compute_ms: f64,
    /// From the simulator; NaN when not simulated.
    pub max_scallop_mm: f64,
    /// UTF-8, NUL-padded (cut at 64 bytes on a character boundary).
    pub job_id: [u8; 64],
    pub strategy: [u8; 32],
    pub machine: [u8; 16],
    pub reserved: [u8; 80],
}

/// One tool position (112 bytes, little-endian).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IpcPoint {
    /// Contact point on the surface, mm.
    pub cc: [f64; 3],
    /// Tool tip (belt: contact-wheel centre), mm.
    pub cl: [f64; 3],
    /// Unit tool axis (belt: wheel axis).
    pub axis: [f64; 3],
    pub uv: [f64; 2],
    /// Machining strip width, mm; NaN when the planner does not give one.
    pub strip_width: f64,
    /// Index of the pass this point belongs to.
    pub pass: u32,
    /// Region of that pass.
    pub region: u32,
    /// Bit 0: first point of its pass.
    pub flags: u32,
    pub reserved: u32,
}

pub const HEADER_SIZE: usize = 256;
pub const POINT_SIZE: usize = 112;
const _: () = assert!(std::mem::size_of::<ToolpathHeader>() == HEADER_SIZE);
const _: () = assert!(std::mem::size_of::<IpcPoint>() == POINT_SIZE);

/// Flag bit: first point of a pass.
pub const FIRST_OF_PASS: u32 = 1;

fn put(buf: &mut [u8], at: usize, bytes: &[u8]) {
    buf[at..at + bytes.len()].copy_from_slice(bytes);
}

fn put_f64s(buf: &mut [u8], at: usize, v: &[f64]) {
    for (k, x) in v.iter().enumerate() {
        put(buf, at + 8 * k, &x.to_le_bytes());
    }
}

fn put_str(buf: &mut [u8], at: usize, len: usize, s: &str) {
    let mut end = s.len().min(len);
    while !s.is_char_boundary(end) {
        end -= 1;
    }
    put(buf, at, &s.as_bytes()[..end]);
}

/// Size in bytes of the payload of `result`.
pub fn payload_size(result: &PlanResult) -> usize {
    HEADER_SIZE + POINT_SIZE * result.point_count()
}

/// Writes `result` into `buf` (exactly [`payload_size`] bytes, zeroed).
pub fn encode_into(result: &PlanResult, sequence: u64, buf: &mut [u8]) -> Result<()> {
    let needed = payload_size(result);
    if buf.len() != needed {
        return Err(Error::invalid(
            "payload",
            format!("{} bytes for a {needed}-byte toolpath", buf.len()),
        ));
    }
    put(buf, 0, &MAGIC);
    put(buf, 4, &VERSION.to_le_bytes());
    put(buf, 8, &(HEADER_SIZE as u32).to_le_bytes());
    put(buf, 12, &(POINT_SIZE as u32).to_le_bytes());
    put(buf, 16, &(result.point_count() as u64).to_le_bytes());
    put(buf, 24, &(result.passes.len() as u64).to_le_bytes());
    put(buf, 32, &sequence.to_le_bytes());
    put_f64s(
        buf,
        40,
        &[
            result.stats.path_length_mm,
            result.stats.compute_ms,
            result.stats.max_scallop_mm.unwrap_or(f64::NAN),
        ],
    );
    put_str(buf, 64, 64, &result.job_id);
    put_str(buf, 128, 32, &result.strategy);
    put_str(buf, 160, 16, result.machine.as_deref().unwrap_or(""));
    let mut at = HEADER_SIZE;
    for (k, pass) in result.passes.iter().enumerate() {
        for (i, p) in pass.points.iter().enumerate() {
            let chunk = &mut buf[at..at + POINT_SIZE];
            put_f64s(chunk, 0, &p.cc);
            put_f64s(chunk, 24, &p.cl);
            put_f64s(chunk, 48, &p.axis);
            put_f64s(chunk, 72, &p.uv);
            put_f64s(chunk, 88, &[p.strip_width.unwrap_or(f64::NAN)]);
            put(chunk, 96, &(k as u32).to_le_bytes());
            put(chunk, 100, &(pass.region as u32).to_le_bytes());
            put(
                chunk,
                104,
                &(if i == 0 { FIRST_OF_PASS } else { 0 }).to_le_bytes(),
            );
            at += POINT_SIZE;
        }
    }
    Ok(())
}

/// The payload of `result` as a new buffer (for tests and non-iceoryx2 use).
pub fn encode(result: &PlanResult, sequence: u64) -> Result<Vec<u8>> {
    let mut buf = vec![0u8; payload_size(result)];
    encode_into(result, sequence, &mut buf)?;
    Ok(buf)
}

fn f64_at(b: &[u8], at: usize) -> f64 {
    let mut a = [0u8; 8];
    a.copy_from_slice(&b[at..at + 8]);
    f64::from_le_bytes(a)
}

fn u32_at(b: &[u8], at: usize) -> u32 {
    let mut a = [0u8; 4];
    a.copy_from_slice(&b[at..at + 4]);
    u32::from_le_bytes(a)
}

fn u64_at(b: &[u8], at: usize) -> u64 {
    let mut a = [0u8; 8];
    a.copy_from_slice(&b[at..at + 8]);
    u64::from_le_bytes(a)
}

fn str_at(b: &[u8], at: usize, len: usize) -> String {
    let s = &b[at..at + len];
    let end = s.iter().position(|&c| c == 0).unwrap_or(len);
    String::from_utf8_lossy(&s[..end]).into_owned()
}

/// A payload read back (what a consumer sees).
#[derive(Clone, Debug, PartialEq)]
pub struct DecodedToolpath {
    pub sequence: u64,
    pub job_id: String,
    pub strategy: String,
    pub machine: String,
    pub pass_count: u64,
    pub path_length_mm: f64,
    pub compute_ms: f64,
    pub max_scallop_mm: f64,
    pub points: Vec<IpcPoint>,
}

/// Parses a payload; errors say what is wrong with it.
pub fn decode(b: &[u8]) -> Result<DecodedToolpath> {
    if b.len() < HEADER_SIZE {
        return Err(Error::invalid(
            "payload",
            format!(
                "{} bytes is shorter than the {HEADER_SIZE}-byte header",
                b.len()
            ),
        ));
    }
    if b[..4] != MAGIC {
        return Err(Error::invalid(
            "payload.magic",
            "not a toolpath payload (magic is not TPTH)",
        ));
    }
    let version = u32_at(b, 4);
    if version != VERSION {
        return Err(Error::invalid(
            "payload.version",
            format!("layout version {version}, this build reads {VERSION}"),
        ));
    }
    let (hs, ps) = (u32_at(b, 8) as usize, u32_at(b, 12) as usize);
    let count = u64_at(b, 16);
    if hs != HEADER_SIZE || ps != POINT_SIZE {
        return Err(Error::invalid(
            "payload.header_size",
            format!("header {hs} / point {ps} bytes, expected {HEADER_SIZE} / {POINT_SIZE}"),
        ));
    }
    let needed = (count as u128) * POINT_SIZE as u128 + HEADER_SIZE as u128;
    if needed != b.len() as u128 {
        return Err(Error::invalid(
            "payload.point_count",
            format!(
                "{count} points need {needed} bytes, the payload has {}",
                b.len()
            ),
        ));
    }
    let points = b[HEADER_SIZE..]
        .chunks_exact(POINT_SIZE)
        .map(|c| IpcPoint {
            cc: [f64_at(c, 0), f64_at(c, 8), f64_at(c, 16)],
            cl: [f64_at(c, 24), f64_at(c, 32), f64_at(c, 40)],
            axis: [f64_at(c, 48), f64_at(c, 56), f64_at(c, 64)],
            uv: [f64_at(c, 72), f64_at(c, 80)],
            strip_width: f64_at(c, 88),
            pass: u32_at(c, 96),
            region: u32_at(c, 100),
            flags: u32_at(c, 104),
            reserved: u32_at(c, 108),
        })
        .collect();
    Ok(DecodedToolpath {
        sequence: u64_at(b, 32),
        job_id: str_at(b, 64, 64),
        strategy: str_at(b, 128, 32),
        machine: str_at(b, 160, 16),
        pass_count: u64_at(b, 24),
        path_length_mm: f64_at(b, 40),
        compute_ms: f64_at(b, 48),
        max_scallop_mm: f64_at(b, 56),
        points,
    })
}

fn ipc_error(what: &str, e: impl std::fmt::Display) -> Error {
    Error::ipc(format!("{what}: {e}"))
}

/// A node with the default configuration, or with file-name prefix `prefix`
/// (tests use their own prefix so that they can check their files are gone).
fn create_node(prefix: Option<&str>) -> Result<Node<ipc::Service>> {
    let mut builder = NodeBuilder::new();
    if let Some(prefix) = prefix {
        let mut config = iceoryx2::config::Config::default();
        config.global.prefix =
            iceoryx2::prelude::FileName::new(prefix.as_bytes()).map_err(|e| {
                Error::invalid(
                    "ipc.prefix",
                    format!("\"{prefix}\" is not a valid file-name prefix: {e:?}"),
                )
            })?;
        builder = builder.config(&config);
    }
    builder
        .create::<ipc::Service>()
        .map_err(|e| ipc_error("cannot create an iceoryx2 node", e))
}

fn service_name(name: &str) -> Result<ServiceName> {
    ServiceName::new(name).map_err(|e| {
        Error::invalid(
            "ipc.service",
            format!("\"{name}\" is not a valid iceoryx2 service name: {e:?}"),
        )
    })
}

/// Publishes toolpaths on an iceoryx2 service. Not `Send`: create it on the
/// thread that publishes.
pub struct ToolpathPublisher {
    // Field order: the publisher and service go before the node that owns them.
    publisher: iceoryx2::port::publisher::Publisher<ipc::Service, [u8], ()>,
    _service:
        iceoryx2::service::port_factory::publish_subscribe::PortFactory<ipc::Service, [u8], ()>,
    _node: Node<ipc::Service>,
    sequence: u64,
}

impl ToolpathPublisher {
    /// Opens (or creates) `service` (normally [`SERVICE_NAME`]).
    pub fn new(service: &str) -> Result<Self> {
        Self::with_prefix(service, None)
    }

    /// Like [`Self::new`], with iceoryx2 file-name prefix `prefix`.
    pub fn with_prefix(service: &str, prefix: Option<&str>) -> Result<Self> {
        let node = create_node(prefix)?;
        let svc = node
            .service_builder(&service_name(service)?)
            .publish_subscribe::<[u8]>()
            .open_or_create()
            .map_err(|e| ipc_error(&format!("cannot open service {service}"), e))?;
        let publisher = svc
            .publisher_builder()
            .initial_max_slice_len(64 * 1024)
            .allocation_strategy(AllocationStrategy::PowerOfTwo)
            .create()
            .map_err(|e| ipc_error("cannot create the publisher", e))?;
        Ok(ToolpathPublisher {
            publisher,
            _service: svc,
            _node: node,
            sequence: 0,
        })
    }

    /// Sends `result`; returns the payload size in bytes.
    pub fn publish(&mut self, result: &PlanResult) -> Result<usize> {
        let size = payload_size(result);
        let mut sample = self
            .publisher
            .loan_slice(size)
            .map_err(|e| ipc_error(&format!("cannot loan {size} bytes"), e))?;
        self.sequence += 1;
        encode_into(result, self.sequence, sample.payload_mut())?;
        sample.send().map_err(|e| ipc_error("send failed", e))?;
        Ok(size)
    }
}

/// Receives toolpaths (for Rust consumers, tests and the benchmark).
pub struct ToolpathSubscriber {
    subscriber: iceoryx2::port::subscriber::Subscriber<ipc::Service, [u8], ()>,
    _service:
        iceoryx2::service::port_factory::publish_subscribe::PortFactory<ipc::Service, [u8], ()>,
    node: Node<ipc::Service>,
}

impl ToolpathSubscriber {
    pub fn new(service: &str) -> Result<Self> {
        Self::with_prefix(service, None)
    }

    /// Like [`Self::new`], with iceoryx2 file-name prefix `prefix`.
    pub fn with_prefix(service: &str, prefix: Option<&str>) -> Result<Self> {
        let node = create_node(prefix)?;
        let svc = node
            .service_builder(&service_name(service)?)
            .publish_subscribe::<[u8]>()
            .open_or_create()
            .map_err(|e| ipc_error(&format!("cannot open service {service}"), e))?;
        let subscriber = svc
            .subscriber_builder()
            .create()
            .map_err(|e| ipc_error("cannot create the subscriber", e))?;
        Ok(ToolpathSubscriber {
            subscriber,
            _service: svc,
            node,
        })
    }

    /// Calls `f` on the payload bytes of the next toolpath, in place in shared
    /// memory, waiting up to `timeout`. `Ok(None)` on timeout.
    pub fn receive_with<T>(
        &self,
        timeout: std::time::Duration,
        f: impl FnOnce(&[u8]) -> T,
    ) -> Result<Option<T>> {
        let deadline = std::time::Instant::now() + timeout;
        loop {
            if let Some(sample) = self
                .subscriber
                .receive()
                .map_err(|e| ipc_error("receive failed", e))?
            {
                return Ok(Some(f(sample.payload())));
            }
            let now = std::time::Instant::now();
            if now >= deadline {
                return Ok(None);
            }
            let step = (deadline - now).min(std::time::Duration::from_micros(200));
            if self.node.wait(step).is_err() {
                return Ok(None);
            }
        }
    }

    /// The next toolpath, decoded (copied out of shared memory).
    pub fn receive(&self, timeout: std::time::Duration) -> Result<Option<DecodedToolpath>> {
        self.receive_with(timeout, decode)?.transpose()
    }
}
