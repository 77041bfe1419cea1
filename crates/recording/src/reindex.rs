//! `toolpath bag reindex BAG`: makes a bag whose writer was killed readable
//! by the standard readers, as `ros2 bag reindex` does. A killed writer
//! leaves completed chunks but no summary section, footer or final
//! metadata.yaml; readers that seek to the summary (Python `mcap`,
//! `rosbags`) then see nothing. The completed chunks are read and written
//! again as a finished file with its summary, then swapped in with renames.

use super::runs::{topic_specs, topic_specs_in};
use super::{read_bag, BagSummary, BagWriter, RecordedTopic, TopicSpec, WriterOptions};
use std::path::Path;
use toolpath_kernel::error::{Error, Result};

/// The node's topic spec of a recorded topic in any namespace.
fn spec_of(recorded: &RecordedTopic) -> Result<TopicSpec> {
    for root in topic_specs() {
        let Some(ns) = recorded.topic.strip_suffix(&root.topic) else {
            continue;
        };
        let ns = if ns.is_empty() { "/" } else { ns };
        if let Some(spec) = topic_specs_in(ns)
            .into_iter()
            .find(|s| s.topic == recorded.topic && s.type_name == recorded.type_name)
        {
            return Ok(spec);
        }
    }
    Err(Error::invalid(
        recorded.topic.clone(),
        format!(
            "{} is not a topic of the node: only node bags can be reindexed",
            recorded.type_name
        ),
    ))
}

/// Rewrites the bag directory `dir` with a summary and metadata.yaml; returns
/// what the new file holds and why the old one stopped (if it did).
pub fn reindex(dir: &Path) -> Result<(BagSummary, Option<String>)> {
    let shown = dir.display().to_string();
    if !dir.is_dir() {
        return Err(Error::invalid(shown, "is not a bag directory"));
    }
    let bag = read_bag(dir)?;
    let [file] = bag.files.as_slice() else {
        return Err(Error::invalid(
            shown,
            format!(
                "has {} storage files: reindex handles bags of one file",
                bag.files.len()
            ),
        ));
    };
    let file_name = file
        .file_name()
        .and_then(|n| n.to_str())
        .ok_or_else(|| Error::invalid(&shown, "storage file name is not UTF-8"))?
        .to_string();
    let tmp = dir.join(".reindex");
    if tmp.exists() {
        std::fs::remove_dir_all(&tmp).map_err(|e| Error::io(tmp.display().to_string(), e))?;
    }
    let mut writer = BagWriter::create_file(&tmp, Some(&file_name), WriterOptions::default())?;
    for recorded in bag.topics.values() {
        writer.add_topic(&spec_of(recorded)?)?;
    }
    for m in &bag.messages {
        writer.write_raw(&m.topic, m.log_time, &m.data)?;
    }
    let mut summary = writer.finish()?;
    for name in [file_name.as_str(), "metadata.yaml"] {
        let (from, to) = (tmp.join(name), dir.join(name));
        std::fs::rename(&from, &to).map_err(|e| Error::io(to.display().to_string(), e))?;
    }
    std::fs::remove_dir_all(&tmp).map_err(|e| Error::io(tmp.display().to_string(), e))?;
    summary.directory = dir.to_path_buf();
    summary.mcap = dir.join(&file_name);
    Ok((summary, bag.truncated))
}
