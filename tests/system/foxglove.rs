//! The match in Foxglove, from a live server process with simulated robots:
//! - its match log holds the scene (`foxglove.SceneUpdate` on `/scene` and `/scene/pitch`,
//!   `foxglove.FrameTransforms` on `/tf`), decoded here with the schema the file carries,
//!   with the pitch, every robot and the ball where the log's own messages put them;
//! - a Foxglove WebSocket client (`serve --foxglove`) is told the channels, subscribes and
//!   receives the scene, decoded with the schema the server advertised;
//! - `replay --out` draws the scene into a log that has none (an older version's), and
//!   replaces, not duplicates, the scene of one that has.

mod support;

use base64::Engine as _;
use futures_util::{SinkExt, StreamExt};
use prost_reflect::{DescriptorPool, DynamicMessage, MessageDescriptor};
use proto::Stamp;
use serde_json::Value;
use std::collections::BTreeMap;
use std::path::Path;
use std::time::Duration;
use support::*;
use tokio_tungstenite::tungstenite::{Message, client::IntoClientRequest};

const ROBOTS: [&str; 3] = ["miro1", "miro2", "miro3"];

/// A message type from a serialised `FileDescriptorSet` (as MCAP and Foxglove carry it).
fn descriptor(set: &[u8], name: &str) -> MessageDescriptor {
    let pool = DescriptorPool::decode(set).expect("a FileDescriptorSet");
    pool.get_message_by_name(name)
        .unwrap_or_else(|| panic!("{name} in the schema"))
}

/// A protobuf message decoded with `desc`, as JSON (field names as in the .proto).
fn decode(desc: &MessageDescriptor, bytes: &[u8]) -> Value {
    let m = DynamicMessage::decode(desc.clone(), bytes).expect("decodes with its schema");
    let options = prost_reflect::SerializeOptions::new()
        .use_proto_field_name(true)
        .skip_default_fields(false);
    m.serialize_with_options(serde_json::value::Serializer, &options)
        .expect("as JSON")
}

/// One message of a log: topic, schema name, log time, payload, and the schema itself.
struct Logged {
    topic: String,
    schema: String,
    log_time: u64,
    data: Vec<u8>,
    schema_data: Vec<u8>,
}

fn read_mcap(path: &Path) -> Vec<Logged> {
    let bytes = std::fs::read(path).expect("log file");
    mcap::MessageStream::new(&bytes)
        .expect("MCAP")
        .map(|m| {
            let m = m.expect("a message");
            let schema = m.channel.schema.as_ref().expect("a schema");
            Logged {
                topic: m.channel.topic.clone(),
                schema: schema.name.clone(),
                log_time: m.log_time,
                data: m.data.into_owned(),
                schema_data: schema.data.to_vec(),
            }
        })
        .collect()
}

fn entity<'a>(scene: &'a Value, id: &str) -> Option<&'a Value> {
    scene["entities"].as_array()?.iter().find(|e| e["id"] == id)
}

/// The x, y of a primitive's pose.
fn xy(primitive: &Value) -> [f64; 2] {
    let p = &primitive["pose"]["position"];
    [
        p["x"].as_f64().unwrap_or(f64::NAN),
        p["y"].as_f64().unwrap_or(f64::NAN),
    ]
}

fn close(a: [f64; 2], b: [f64; 2]) -> bool {
    (a[0] - b[0]).abs() < 1e-6 && (a[1] - b[1]).abs() < 1e-6
}

/// Checks a log's scene against the log's own messages: the pitch, every robot at its last
/// reported pose and the ball at the state logged at the same time. Returns the number of
/// scene updates.
fn check_scene(log: &[Logged]) -> usize {
    let scene_msgs: Vec<&Logged> = log.iter().filter(|m| m.topic == "/scene").collect();
    assert!(scene_msgs.len() > 20, "{} scene updates", scene_msgs.len());
    assert!(
        scene_msgs
            .iter()
            .all(|m| m.schema == "foxglove.SceneUpdate")
    );
    let desc = descriptor(&scene_msgs[0].schema_data, "foxglove.SceneUpdate");

    let pitch = log
        .iter()
        .find(|m| m.topic == "/scene/pitch")
        .expect("the pitch");
    let pitch = decode(&desc, &pitch.data);
    let p = entity(&pitch, "pitch").expect("the pitch entity");
    assert_eq!(p["frame_id"], "pitch");
    assert_eq!(
        p["cubes"].as_array().map(Vec::len),
        Some(5),
        "floor and 4 walls"
    );
    for c in p["lines"][0]["points"].as_array().expect("outline") {
        let (x, y) = (
            c["x"].as_f64().unwrap_or(0.0),
            c["y"].as_f64().unwrap_or(0.0),
        );
        assert!(
            (x.abs() - 1.95).abs() < 1e-9 && (y.abs() - 1.3).abs() < 1e-9,
            "{c}"
        );
    }

    // Ball states and robots' poses by time.
    let states: BTreeMap<u64, [f64; 2]> = log
        .iter()
        .filter(|m| m.schema == "BallState")
        .map(|m| {
            let s: proto::BallState = proto::decode(&m.data).expect("a state");
            (m.log_time, s.position_m)
        })
        .collect();
    let mut checked_ball = 0;
    let mut checked_robots = 0;
    // In file order, which is the order the server applied and drew things (a status is
    // logged when applied, under the same lock as the scene, though stamped on arrival).
    let mut poses: BTreeMap<String, [f64; 2]> = BTreeMap::new();
    for m in log {
        if m.schema == "RobotStatus" {
            let st: proto::RobotStatus = proto::decode(&m.data).expect("a status");
            poses.insert(st.robot_id.clone(), [st.pose.x_m, st.pose.y_m]);
            continue;
        }
        if m.topic != "/scene" {
            continue;
        }
        let scene = decode(&desc, &m.data);
        if let (Some(ball), Some(at)) = (entity(&scene, "ball"), states.get(&m.log_time)) {
            let drawn = xy(&ball["spheres"][0]);
            assert!(
                close(drawn, *at),
                "ball drawn at {drawn:?}, state at {at:?}"
            );
            checked_ball += 1;
        }
        for robot in ROBOTS {
            let Some(e) = entity(&scene, &format!("robot/{robot}")) else {
                continue;
            };
            if let Some(pose) = poses.get(robot) {
                let drawn = xy(&e["cylinders"][0]);
                assert!(
                    close(drawn, *pose),
                    "{robot} drawn at {drawn:?}, status says {pose:?}"
                );
                checked_robots += 1;
            }
        }
    }
    assert!(checked_ball > 10, "ball checked in {checked_ball} updates");
    assert!(checked_robots > 20, "robots checked {checked_robots} times");
    // Every robot is in the last update.
    let last = decode(&desc, &scene_msgs[scene_msgs.len() - 1].data);
    for robot in ROBOTS {
        assert!(
            entity(&last, &format!("robot/{robot}")).is_some(),
            "{robot} in {last}"
        );
    }
    let tf = log.iter().find(|m| m.topic == "/tf").expect("transforms");
    let tf_desc = descriptor(&tf.schema_data, "foxglove.FrameTransforms");
    let tf = decode(&tf_desc, &tf.data);
    assert!(
        tf["transforms"]
            .as_array()
            .is_some_and(|t| t.iter().all(|t| t["parent_frame_id"] == "pitch"))
    );
    scene_msgs.len()
}

/// A Foxglove WebSocket client: the channels it is told of, then the first `/scene` update
/// holding the ball and every robot, decoded with the advertised schema.
async fn foxglove_client(url: &str) -> Value {
    let mut request = url.into_client_request().expect("request");
    request.headers_mut().insert(
        "Sec-WebSocket-Protocol",
        "foxglove.websocket.v1".parse().expect("header"),
    );
    let (mut ws, response) = tokio_tungstenite::connect_async(request)
        .await
        .expect("connects");
    assert_eq!(
        response
            .headers()
            .get("sec-websocket-protocol")
            .map(|v| v.as_bytes()),
        Some(&b"foxglove.websocket.v1"[..])
    );
    let mut server_info = false;
    let mut scene: Option<(u64, MessageDescriptor)> = None;
    loop {
        let msg = ws.next().await.expect("open").expect("a message");
        match msg {
            Message::Text(t) => {
                let v: Value = serde_json::from_str(t.as_str()).expect("JSON");
                match v["op"].as_str() {
                    Some("serverInfo") => server_info = true,
                    Some("advertise") => {
                        for c in v["channels"].as_array().expect("channels") {
                            if c["topic"] == "/scene" {
                                assert_eq!(c["encoding"], "protobuf");
                                assert_eq!(c["schemaEncoding"], "protobuf");
                                let set = base64::engine::general_purpose::STANDARD
                                    .decode(c["schema"].as_str().expect("schema"))
                                    .expect("base64");
                                let id = c["id"].as_u64().expect("id");
                                scene = Some((id, descriptor(&set, "foxglove.SceneUpdate")));
                                let sub = serde_json::json!({"op": "subscribe",
                                    "subscriptions": [{"id": 42, "channelId": id}]});
                                ws.send(Message::Text(sub.to_string().into()))
                                    .await
                                    .expect("subscribe");
                            }
                        }
                    }
                    _ => {}
                }
            }
            Message::Binary(b) => {
                assert!(server_info, "serverInfo comes first");
                assert_eq!(b[0], 1, "message data");
                assert_eq!(
                    u32::from_le_bytes([b[1], b[2], b[3], b[4]]),
                    42,
                    "our subscription"
                );
                let (_, desc) = scene.as_ref().expect("subscribed");
                let update = decode(desc, &b[13..]);
                let all_robots = ROBOTS
                    .iter()
                    .all(|r| entity(&update, &format!("robot/{r}")).is_some());
                if entity(&update, "ball").is_some() && all_robots {
                    let _ = ws.close(None).await;
                    return update;
                }
            }
            Message::Close(_) => panic!("the server closed the connection"),
            _ => {}
        }
    }
}

fn replay_json(log: &Path, out: &Path) -> Value {
    let output = std::process::Command::new(server_bin())
        .args(["replay", "--json", "--out"])
        .arg(out)
        .arg(log)
        .output()
        .expect("replay runs");
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    serde_json::from_slice(&output.stdout).expect("replay summary")
}

#[tokio::test(flavor = "multi_thread")]
async fn the_match_is_a_foxglove_scene_live_in_the_log_and_after_replay() {
    let dir = temp_dir("foxglove");
    let record = dir.join("live");
    let record_arg = record.to_string_lossy().into_owned();
    let (mut server, endpoint, addr) = start_server(&[
        "--record",
        &record_arg,
        "--foxglove",
        "127.0.0.1:0",
        "--id",
        "fox",
    ]);
    let ws = server.line_starting("foxglove ws://", Duration::from_secs(30));
    let url = ws.trim_start_matches("foxglove ").to_string();
    let start = Stamp(now_ns()).offset_secs(1.0).0.to_string();
    let mut robots = Proc::robots(&[
        "--connect",
        &endpoint,
        "--scenario",
        "match",
        "--team-size",
        "3",
        "--seed",
        "2",
        "--duration-s",
        "8",
        "--start-ns",
        &start,
    ]);

    let update = tokio::time::timeout(Duration::from_secs(40), foxglove_client(&url))
        .await
        .expect("the scene reaches a Foxglove client");
    let ball = entity(&update, "ball").expect("ball");
    let [x, y] = xy(&ball["spheres"][0]);
    assert!(
        x.abs() <= 1.95 && y.abs() <= 1.3,
        "ball on the pitch: {x}, {y}"
    );
    let sent = metric(&addr, "rf_foxglove_messages_sent_total");
    assert!(sent > 0.0, "counted: {sent}");

    tokio::task::spawn_blocking(move || {
        wait_for("robots to finish", Duration::from_secs(60), || {
            robots.child.try_wait().ok().flatten()
        });
        assert!(server.terminate(Duration::from_secs(20)).success());
    })
    .await
    .expect("stopped");

    let files = mcap_files(&record);
    assert_eq!(files.len(), 1, "{files:?}");
    let live_log = read_mcap(&files[0]);
    let live_updates = check_scene(&live_log);

    // An older version's log: the same match without the scene.
    let old = dir.join("old.mcap");
    {
        let mut w = mcap::Writer::new(std::io::BufWriter::new(
            std::fs::File::create(&old).expect("old log"),
        ))
        .expect("writer");
        let mut channels = BTreeMap::new();
        for m in live_log
            .iter()
            .filter(|m| !m.topic.starts_with("/scene") && m.topic != "/tf")
        {
            let id = *channels.entry(m.topic.clone()).or_insert_with(|| {
                let s = w
                    .add_schema(&m.schema, "jsonschema", &m.schema_data)
                    .expect("schema");
                w.add_channel(s, &m.topic, "json", &BTreeMap::new())
                    .expect("channel")
            });
            w.write_to_known_channel(
                &mcap::records::MessageHeader {
                    channel_id: id,
                    sequence: 0,
                    log_time: m.log_time,
                    publish_time: m.log_time,
                },
                &m.data,
            )
            .expect("write");
        }
        w.finish().expect("finish");
    }
    let out = dir.join("replayed-old");
    let summary = replay_json(&old, &out);
    assert_eq!(summary["scene_replaced"], 0);
    assert!(
        summary["scene_written"].as_u64().is_some_and(|n| n > 20),
        "{summary}"
    );
    let replayed = read_mcap(&mcap_files(&out)[0]);
    check_scene(&replayed);

    // A log with a scene: replaced, not doubled.
    let out = dir.join("replayed-live");
    let summary = replay_json(&files[0], &out);
    let replaced = summary["scene_replaced"].as_u64().unwrap_or(0);
    assert!(replaced >= 2 * live_updates as u64, "{summary}");
    let replayed = read_mcap(&mcap_files(&out)[0]);
    let updates = check_scene(&replayed);
    assert!(
        updates.abs_diff(live_updates) <= live_updates / 5 + 2,
        "{updates} updates after replay, {live_updates} live"
    );
    let _ = std::fs::remove_dir_all(&dir);
}
