//! rosbag2 MCAP recording: round trip, the bytes ROS 2 expects, chunking and
//! compression, truncated files, a writer killed with SIGKILL, bad bags.

use serde::{Deserialize, Serialize};
use std::path::Path;
use toolpath_planner::recording::{self, read_bag, BagWriter, Qos, TopicSpec, WriterOptions};

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
struct Point {
    x: f64,
    y: f64,
    z: f64,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
struct Path3 {
    id: String,
    count: u32,
    points: Vec<Point>,
    flag: u8,
}

const POINT_DEF: &str = "float64 x\nfloat64 y\nfloat64 z\n";

fn path_spec() -> TopicSpec {
    let def = format!(
        "string id   # path name\nuint32 count\ngeometry_msgs/Point[] points\nuint8 flag\n{}\nMSG: geometry_msgs/Point\n{POINT_DEF}",
        recording::DEFINITION_SEPARATOR
    );
    TopicSpec::new(
        "/path",
        "test_msgs/msg/Path3",
        &def,
        Qos::reliable_transient_local(100),
    )
}

fn message(i: u32) -> Path3 {
    Path3 {
        id: format!("path {i}"),
        count: i,
        points: (0..50)
            .map(|k| Point {
                x: k as f64,
                y: (i * 2) as f64,
                z: 0.5 * k as f64,
            })
            .collect(),
        flag: (i % 3) as u8,
    }
}

fn write_bag(dir: &Path, n: u32, options: WriterOptions) -> recording::BagSummary {
    let mut w = BagWriter::create(dir, options).unwrap();
    w.add_topic(&path_spec()).unwrap();
    for i in 0..n {
        w.write("/path", 1_000_000_000 + i as u64 * 1000, &message(i))
            .unwrap();
    }
    w.finish().unwrap()
}

#[test]
fn cdr_bytes_are_what_ros2_sends() {
    #[derive(Serialize)]
    struct M {
        a: u32,
        s: String,
        d: f64,
    }
    let bytes = recording::to_cdr(&M {
        a: 7,
        s: "ab".into(),
        d: 1.5,
    })
    .unwrap();
    let mut expected = vec![0x00, 0x01, 0x00, 0x00];
    expected.extend_from_slice(&7u32.to_le_bytes());
    expected.extend_from_slice(&3u32.to_le_bytes()); // length with the NUL
    expected.extend_from_slice(b"ab\0");
    expected.extend_from_slice(&[0; 5]); // pad body offset 11 -> 16 for the f64
    expected.extend_from_slice(&1.5f64.to_le_bytes());
    assert_eq!(bytes, expected);
}

#[test]
fn round_trip_directory_and_mcap() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("run1");
    let s = write_bag(
        &dir,
        40,
        WriterOptions {
            chunk_size: 4096,
            ..Default::default()
        },
    );
    assert!(dir.join("run1_0.mcap").is_file());
    assert_eq!(s.messages, 40);
    assert!(s.chunks > 3, "small chunks: {}", s.chunks);
    // zstd really compresses these repetitive messages.
    assert!(
        s.file_bytes * 2 < s.uncompressed_bytes,
        "{} vs {}",
        s.file_bytes,
        s.uncompressed_bytes
    );

    for path in [dir.clone(), dir.join("run1_0.mcap")] {
        let bag = read_bag(&path).unwrap();
        assert!(bag.truncated.is_none());
        assert_eq!(bag.messages.len(), 40);
        let t = &bag.topics["/path"];
        assert_eq!(t.type_name, "test_msgs/msg/Path3");
        assert_eq!(t.schema_encoding, "ros2msg");
        assert_eq!(t.message_encoding, "cdr");
        assert!(t.definition.contains("\nMSG: geometry_msgs/Point\n"));
        let qos: serde_yaml_ng::Value = serde_yaml_ng::from_str(&t.offered_qos_profiles).unwrap();
        assert_eq!(qos[0]["durability"].as_str(), Some("transient_local"));
        assert_eq!(qos[0]["reliability"].as_str(), Some("reliable"));
        assert_eq!(qos[0]["depth"].as_u64(), Some(100));
        for (i, _) in bag.messages.iter().enumerate() {
            let m: Path3 = bag.decode(i, &path_spec()).unwrap();
            assert_eq!(m, message(i as u32));
        }
    }
    // metadata.yaml as rosbag2 version 9 reads it.
    let meta: serde_yaml_ng::Value =
        serde_yaml_ng::from_str(&std::fs::read_to_string(dir.join("metadata.yaml")).unwrap())
            .unwrap();
    let info = &meta["rosbag2_bagfile_information"];
    assert_eq!(info["version"].as_u64(), Some(9));
    assert_eq!(info["storage_identifier"].as_str(), Some("mcap"));
    assert_eq!(info["message_count"].as_u64(), Some(40));
    assert_eq!(info["relative_file_paths"][0].as_str(), Some("run1_0.mcap"));
    assert_eq!(info["files"][0]["message_count"].as_u64(), Some(40));
    assert_eq!(info["duration"]["nanoseconds"].as_u64(), Some(39_000));
    assert_eq!(
        info["starting_time"]["nanoseconds_since_epoch"].as_u64(),
        Some(1_000_000_000)
    );
    let topic = &info["topics_with_message_count"][0];
    assert_eq!(topic["message_count"].as_u64(), Some(40));
    assert_eq!(
        topic["topic_metadata"]["type"].as_str(),
        Some("test_msgs/msg/Path3")
    );
    assert_eq!(
        topic["topic_metadata"]["serialization_format"].as_str(),
        Some("cdr")
    );
    assert_eq!(
        topic["topic_metadata"]["offered_qos_profiles"][0]["history"].as_str(),
        Some("keep_last")
    );
    assert!(info["custom_data"].is_mapping());
    assert_eq!(info["ros_distro"].as_str(), Some("jazzy"));
    if let Ok(keep) = std::env::var("TOOLPATH_BAG_KEEP") {
        // For checking by hand with other readers.
        let keep = Path::new(&keep).join("test_bag");
        let _ = std::fs::remove_dir_all(&keep);
        write_bag(
            &keep,
            40,
            WriterOptions {
                chunk_size: 4096,
                ..Default::default()
            },
        );
    }
}

#[test]
fn truncated_file_keeps_completed_chunks() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("full");
    write_bag(
        &dir,
        60,
        WriterOptions {
            chunk_size: 2048,
            ..Default::default()
        },
    );
    let bytes = std::fs::read(dir.join("full_0.mcap")).unwrap();
    let full = read_bag(&dir).unwrap();
    let mut recovered_counts = Vec::new();
    for cut in [
        bytes.len() / 4,
        bytes.len() / 2,
        bytes.len() * 3 / 4,
        bytes.len() - 10,
    ] {
        let p = tmp.path().join(format!("cut{cut}.mcap"));
        std::fs::write(&p, &bytes[..cut]).unwrap();
        let bag = read_bag(&p).unwrap();
        let why = bag.truncated.clone().expect("reported as truncated");
        assert!(why.contains("truncated"), "{why}");
        // What is recovered is an exact prefix of the recording.
        assert_eq!(bag.messages[..], full.messages[..bag.messages.len()]);
        recovered_counts.push(bag.messages.len());
    }
    assert!(
        recovered_counts[0] > 0 && recovered_counts[0] < 60,
        "{recovered_counts:?}"
    );
    assert!(recovered_counts.windows(2).all(|w| w[0] <= w[1]));
    assert_eq!(
        *recovered_counts.last().unwrap(),
        60,
        "cut in the summary loses nothing"
    );
    // Cut inside the header: nothing to recover, a clear error.
    let p = tmp.path().join("tiny.mcap");
    std::fs::write(&p, &bytes[..12]).unwrap();
    let e = read_bag(&p).unwrap_err().to_string();
    assert!(e.contains("tiny.mcap"), "{e}");
}

/// Not a test by itself: the child process of `killed_writer_leaves_readable_chunks`.
#[test]
fn child_writer_until_killed() {
    let Ok(dir) = std::env::var("TOOLPATH_TEST_BAG_CHILD") else {
        return;
    };
    let mut w = BagWriter::create(
        Path::new(&dir),
        WriterOptions {
            chunk_size: 1024,
            ..Default::default()
        },
    )
    .unwrap();
    w.add_topic(&path_spec()).unwrap();
    let mut i = 0u32;
    loop {
        w.write("/path", 1_000 + i as u64, &message(i)).unwrap();
        i += 1;
        if i.is_multiple_of(10) {
            w.flush().unwrap();
        }
        std::thread::sleep(std::time::Duration::from_millis(2));
    }
}

#[test]
fn killed_writer_leaves_readable_chunks() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("killed");
    let mut child = std::process::Command::new(std::env::current_exe().unwrap())
        .args([
            "--exact",
            "child_writer_until_killed",
            "--nocapture",
            "--test-threads=1",
        ])
        .env("TOOLPATH_TEST_BAG_CHILD", &dir)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let file = dir.join("killed_0.mcap");
    let start = std::time::Instant::now();
    while std::fs::metadata(&file).map(|m| m.len()).unwrap_or(0) < 20_000 {
        assert!(
            start.elapsed().as_secs() < 60,
            "the child writer made no progress"
        );
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    child.kill().unwrap(); // SIGKILL on Unix
    child.wait().unwrap();
    assert!(!dir.join("metadata.yaml").exists());
    let bag = read_bag(&dir).unwrap();
    assert!(bag.truncated.is_some());
    assert!(bag.messages.len() >= 10, "{} messages", bag.messages.len());
    for (i, _) in bag.messages.iter().enumerate() {
        let m: Path3 = bag.decode(i, &path_spec()).unwrap();
        assert_eq!(m, message(i as u32), "messages are complete and in order");
    }
}

#[test]
fn bad_bags_give_clear_errors() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("good");
    write_bag(&dir, 3, WriterOptions::default());
    let bag = read_bag(&dir).unwrap();

    // Wrong schema: same topic and type, other fields.
    let mut other = path_spec();
    other.definition = other.definition.replace("uint8 flag", "uint16 flag");
    let e = bag.check_topic(&other).unwrap_err().to_string();
    assert!(
        e.contains("/path") && e.contains("uint8 flag") && e.contains("uint16 flag"),
        "{e}"
    );
    let e = bag.decode::<Path3>(0, &other).unwrap_err().to_string();
    assert!(e.contains("differs"), "{e}");
    // Wrong type name.
    let mut other = path_spec();
    other.type_name = "test_msgs/msg/Other".into();
    let e = bag.check_topic(&other).unwrap_err().to_string();
    assert!(
        e.contains("test_msgs/msg/Path3") && e.contains("test_msgs/msg/Other"),
        "{e}"
    );
    // Unknown topic.
    let known = [TopicSpec::new(
        "/job",
        "toolpath_msgs/msg/Job",
        "string job_id\n",
        Qos::DEFAULT,
    )];
    let e = bag.check_types(&known).unwrap_err().to_string();
    assert!(e.contains("/path") && e.contains("unknown topic"), "{e}");
    // Payload of another type: decoding fails or leaves bytes over, never panics.
    #[derive(Debug, Deserialize)]
    #[allow(dead_code)]
    struct Small {
        a: u32,
    }
    assert!(recording::from_cdr::<Small>(&bag.messages[0].data).is_err());
    assert!(recording::from_cdr::<Path3>(&[0, 1]).is_err());
    assert!(recording::from_cdr::<Path3>(&[0, 1, 0, 0, 200, 0, 0, 0]).is_err());

    // Not an MCAP file.
    let p = tmp.path().join("junk.mcap");
    std::fs::write(&p, b"hello, not a bag at all").unwrap();
    let e = read_bag(&p).unwrap_err().to_string();
    assert!(e.contains("not an MCAP file"), "{e}");
    // Empty directory, missing path.
    let empty = tmp.path().join("empty");
    std::fs::create_dir(&empty).unwrap();
    assert!(read_bag(&empty)
        .unwrap_err()
        .to_string()
        .contains("not a bag"));
    assert!(read_bag(&tmp.path().join("nope")).is_err());
    // Broken metadata.yaml names the field.
    std::fs::write(
        dir.join("metadata.yaml"),
        "rosbag2_bagfile_information:\n  version: nine\n",
    )
    .unwrap();
    let e = read_bag(&dir).unwrap_err().to_string();
    assert!(e.contains("version"), "{e}");
    // Writing into a non-empty directory is refused.
    let e = BagWriter::create(&dir, WriterOptions::default())
        .err()
        .unwrap()
        .to_string();
    assert!(e.contains("not empty"), "{e}");
    // Bad topic names.
    let mut w = BagWriter::create(&tmp.path().join("b2"), WriterOptions::default()).unwrap();
    let e = w
        .add_topic(&TopicSpec::new("path", "x/msg/Y", "int32 a", Qos::DEFAULT))
        .unwrap_err()
        .to_string();
    assert!(e.contains("absolute"), "{e}");
    let e = w
        .add_topic(&TopicSpec::new("/p", "x/Y", "int32 a", Qos::DEFAULT))
        .unwrap_err()
        .to_string();
    assert!(e.contains("pkg/msg/Type"), "{e}");
    assert!(w.write("/unknown", 0, &1u32).is_err());
}
