use std::path::Path;
use toolpath_formats as formats;
use toolpath_ipc::ToolpathPublisher;
use toolpath_kernel::error::Result;

/// `toolpath ipc-publish RESULT`: sends a result file over iceoryx2 `repeat`
/// times (a consumer that attaches late still gets one).
pub fn run(
    result: &Path,
    service: &str,
    prefix: Option<&str>,
    repeat: u32,
    interval_ms: u64,
) -> Result<()> {
    let result = formats::read_result(result)?;
    let mut publisher = ToolpathPublisher::with_prefix(service, prefix)?;
    for i in 0..repeat {
        let bytes = publisher.publish(&result)?;
        if i == 0 {
            eprintln!(
                "publishing {} points ({bytes} bytes) on {service}",
                result.point_count()
            );
        }
        if i + 1 < repeat {
            std::thread::sleep(std::time::Duration::from_millis(interval_ms));
        }
    }
    Ok(())
}
