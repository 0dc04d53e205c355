//! The robots' camera views through a live server process, over real Zenoh and HTTP:
//! - a robot's views are kept (the newest of each camera) and served: `GET /api/views`,
//!   `GET /api/robots/{id}/view/{camera}` (the message) and `…/image` (the JPEG), and the
//!   `/api/views/stream` WebSocket;
//! - bad views (not a JPEG, too large, another robot's id, annotations outside the image, a
//!   flood) are refused with a counted reason, and the robot's observations are unaffected;
//! - the match log holds each view as `foxglove.CompressedImage` and
//!   `foxglove.ImageAnnotations`, decoded here with the schemas the log carries, and its
//!   metadata, which a real-time replay serves again with its image.

mod support;

use futures_util::StreamExt;
use prost_reflect::{DescriptorPool, DynamicMessage};
use proto::net::NetConfig;
use proto::test_support::camera_view;
use proto::{Camera, KeySpace, Stamp};
use std::time::Duration;
use support::*;

fn now() -> Stamp {
    Stamp(now_ns())
}

/// The labelled sample `name{labels}` of `/metrics` (0 when absent).
fn labelled_metric(addr: &str, name: &str, labels: &str) -> f64 {
    let (_, text) = http_get(addr, "/metrics").expect("metrics");
    let prefix = format!("{name}{{{labels}}} ");
    text.lines()
        .find_map(|l| l.strip_prefix(&prefix))
        .and_then(|v| v.trim().parse().ok())
        .unwrap_or(0.0)
}

async fn put(session: &zenoh::Session, key: &str, payload: Vec<u8>) {
    session.put(key, payload).await.expect("put");
}

#[tokio::test(flavor = "multi_thread")]
async fn views_are_kept_served_bounded_and_logged() {
    let dir = temp_dir("views");
    let record = dir.to_string_lossy().into_owned();
    let (mut server, endpoint, addr) = start_server(&["--record", &record]);
    let session = NetConfig::connecting(&endpoint)
        .open()
        .await
        .expect("session");
    let keys = KeySpace::default();
    let left = keys.robot_view("miro1", Camera::Left).expect("key");
    let right = keys.robot_view("miro1", Camera::Right).expect("key");

    // The server is listening once an observation gets through.
    let obs_key = keys.robot_obs("miro1").expect("key");
    wait_for(
        "the server to hear the robot",
        Duration::from_secs(20),
        || {
            let o = proto::test_support::observation("miro1", 0, now(), [0.1, 0.2]);
            futures_executor_put(&session, &obs_key, proto::encode(&o));
            (metric(&addr, "rf_observations_accepted_total") >= 1.0).then_some(())
        },
    );

    let mut ws = {
        let url = format!("ws://{addr}/api/views/stream");
        tokio_tungstenite::connect_async(url)
            .await
            .expect("view stream")
            .0
    };
    put(
        &session,
        &left,
        proto::encode(&camera_view("miro1", Camera::Left, 1, now())),
    )
    .await;
    put(
        &session,
        &right,
        proto::encode(&camera_view("miro1", Camera::Right, 2, now())),
    )
    .await;
    let listed = wait_for("two views", Duration::from_secs(10), || {
        let v = get_json(&addr, "/api/views");
        (v.as_array().map(Vec::len) == Some(2)).then_some(v)
    });
    assert_eq!(listed[0]["view"]["camera"], "left");
    assert_eq!(
        listed[0]["view"]["jpeg_base64"], "",
        "the list leaves the images out"
    );

    let one = get_json(&addr, "/api/robots/miro1/view/right");
    let view: proto::CameraView = serde_json::from_value(one).expect("a CameraView");
    assert_eq!((view.seq, view.camera), (2, Camera::Right));
    assert_eq!(view.candidates.len(), 2);
    assert!(view.jpeg().is_ok(), "the whole message, image included");
    let mut answer = ureq::get(format!("http://{addr}/api/robots/miro1/view/left/image"))
        .call()
        .expect("the image");
    assert_eq!(
        answer
            .headers()
            .get("content-type")
            .and_then(|v| v.to_str().ok()),
        Some("image/jpeg")
    );
    let jpeg = answer.body_mut().read_to_vec().expect("bytes");
    assert_eq!(proto::jpeg_size_px(&jpeg), Some((16, 9)));
    let (code, _) = http_get(&addr, "/api/robots/miro9/view/left").expect("none");
    assert_eq!(code, 404);
    let (code, _) = http_get(&addr, "/api/robots/miro1/view/middle").expect("bad camera");
    assert_eq!(code, 400);

    let pushed = tokio::time::timeout(Duration::from_secs(10), ws.next())
        .await
        .expect("a view pushed")
        .expect("open")
        .expect("a frame");
    let pushed: proto::CameraView =
        serde_json::from_str(pushed.to_text().expect("text")).expect("a view");
    assert_eq!(pushed.robot_id, "miro1");

    // Bad views, each refused with its reason; the robot's observations go on.
    let mut png = camera_view("miro1", Camera::Left, 3, now());
    png.jpeg_base64 = proto::jpeg_base64(b"\x89PNG\r\n\x1a\n not a jpeg, a png header");
    put(&session, &left, proto::encode(&png)).await;
    put(
        &session,
        &left,
        vec![b'{'; proto::MAX_VIEW_PAYLOAD_BYTES + 10],
    )
    .await;
    let claims = camera_view("miro1", Camera::Left, 4, now());
    put(
        &session,
        &keys.robot_view("miro2", Camera::Left).expect("key"),
        proto::encode(&claims),
    )
    .await;
    let mut outside = camera_view("miro1", Camera::Left, 5, now());
    outside.candidates[0].u_px = 99.0;
    put(&session, &left, proto::encode(&outside)).await;
    // A flood: 300 views at once from one robot.
    let flood = keys.robot_view("flood", Camera::Left).expect("key");
    for i in 0..300 {
        put(
            &session,
            &flood,
            proto::encode(&camera_view("flood", Camera::Left, i, now())),
        )
        .await;
    }
    for (reason, at_least) in [
        ("not_jpeg", 1.0),
        ("too_large", 1.0),
        ("wrong_robot", 1.0),
        ("out_of_range", 1.0),
        ("rate_limited", 250.0),
    ] {
        wait_for(reason, Duration::from_secs(10), || {
            let n = labelled_metric(
                &addr,
                "rf_camera_views_refused_total",
                &format!("reason=\"{reason}\""),
            );
            (n >= at_least).then_some(())
        });
    }
    let before = metric(&addr, "rf_observations_accepted_total");
    let o = proto::test_support::observation("miro1", 1, now(), [0.3, 0.2]);
    put(&session, &obs_key, proto::encode(&o)).await;
    wait_for(
        "observations still accepted",
        Duration::from_secs(10),
        || (metric(&addr, "rf_observations_accepted_total") > before).then_some(()),
    );
    let kept = get_json(&addr, "/api/robots/miro1/view/left");
    assert_eq!(kept["seq"], 1, "no refused view replaced the kept one");

    drop(ws);
    let _ = session.close().await;
    assert!(server.terminate(Duration::from_secs(20)).success());

    // The log: each kept view as an image, its annotations and its metadata.
    let files = mcap_files(&dir);
    assert!(!files.is_empty());
    let bytes = std::fs::read(&files[0]).expect("log");
    let mut images = 0;
    let mut annotations = 0;
    let mut metas = 0;
    for m in mcap::MessageStream::new(&bytes).expect("MCAP") {
        let m = m.expect("a message");
        let schema = m.channel.schema.as_ref().expect("a schema");
        let decode = |name: &str| {
            let pool = DescriptorPool::decode(schema.data.as_ref()).expect("descriptors");
            let desc = pool.get_message_by_name(name).expect("the message type");
            DynamicMessage::decode(desc, m.data.as_ref()).expect("decodes with its schema")
        };
        match schema.name.as_str() {
            "foxglove.CompressedImage" => {
                let img = decode("foxglove.CompressedImage");
                let data = img.get_field_by_name("data").expect("data");
                let data = data.as_bytes().expect("bytes");
                assert_eq!(proto::jpeg_size_px(data), Some((16, 9)));
                assert_eq!(
                    img.get_field_by_name("format").expect("format").as_str(),
                    Some("jpeg")
                );
                assert!(m.channel.topic.ends_with("/image"), "{}", m.channel.topic);
                images += 1;
            }
            "foxglove.ImageAnnotations" => {
                let a = decode("foxglove.ImageAnnotations");
                let circles = a.get_field_by_name("circles").expect("circles");
                assert_eq!(circles.as_list().map(<[_]>::len), Some(2));
                annotations += 1;
            }
            "CameraView" => {
                let v: proto::CameraView = proto::decode(&m.data).expect("metadata");
                assert!(v.jpeg_base64.is_empty(), "the image is logged once");
                metas += 1;
            }
            _ => {}
        }
    }
    // miro1's two views and the flood's burst.
    assert!(
        images >= 2 && images == annotations && images == metas,
        "{images} {annotations} {metas}"
    );

    // Played back as if live, the views come back whole.
    let (replay, addr) = {
        let port = proto::net::free_loopback_port().expect("port");
        let listen = format!("tcp/127.0.0.1:{port}");
        let file = files[0].to_string_lossy().into_owned();
        let p = Proc::spawn(&[
            "replay",
            "--realtime",
            "--stay",
            "--speed",
            "4",
            "--listen",
            &listen,
            "--http",
            "127.0.0.1:0",
            &file,
        ]);
        let addr = http_addr(&p);
        (p, addr)
    };
    let again = wait_for("a replayed view", Duration::from_secs(30), || {
        http_get(&addr, "/api/robots/miro1/view/right")
            .ok()
            .filter(|(code, _)| *code == 200)
            .map(|(_, body)| body)
    });
    let again: proto::CameraView = serde_json::from_str(&again).expect("a view");
    assert!(again.jpeg().is_ok(), "whole again");
    drop(replay);
}

/// A put from inside a synchronous polling closure.
fn futures_executor_put(session: &zenoh::Session, key: &str, payload: Vec<u8>) {
    use zenoh::Wait;
    session.put(key, payload).wait().expect("put");
}

/// A Foxglove client of `serve --foxglove` is told of each camera's image and annotation
/// channels as the views come, subscribes, and gets the JPEG and its circles, decoded with
/// the schemas the server advertised.
#[tokio::test(flavor = "multi_thread")]
async fn views_stream_live_to_foxglove() {
    use base64::Engine as _;
    use futures_util::SinkExt;
    use tokio_tungstenite::tungstenite::{client::IntoClientRequest, protocol::Message};

    let (server, endpoint, _addr) = start_server(&["--foxglove", "127.0.0.1:0"]);
    let line = server.line_starting("foxglove ws://", Duration::from_secs(30));
    let url = line.trim_start_matches("foxglove ").to_string();
    let mut request = url.into_client_request().expect("request");
    request.headers_mut().insert(
        "Sec-WebSocket-Protocol",
        "foxglove.websocket.v1".parse().expect("header"),
    );
    let (mut ws, _) = tokio_tungstenite::connect_async(request)
        .await
        .expect("connects");
    let session = NetConfig::connecting(&endpoint)
        .open()
        .await
        .expect("session");
    let key = KeySpace::default()
        .robot_view("miro1", Camera::Left)
        .expect("key");
    let mut wanted: std::collections::BTreeMap<u64, (String, prost_reflect::MessageDescriptor)> =
        Default::default();
    let mut got = std::collections::BTreeSet::new();
    let mut seq = 0;
    let deadline = tokio::time::Instant::now() + Duration::from_secs(30);
    while got.len() < 2 {
        assert!(
            tokio::time::Instant::now() < deadline,
            "got {got:?} of the two channels"
        );
        // A view every 300 ms until both channels have delivered one.
        put(
            &session,
            &key,
            proto::encode(&camera_view("miro1", Camera::Left, seq, now())),
        )
        .await;
        seq += 1;
        let Ok(Some(Ok(msg))) = tokio::time::timeout(Duration::from_millis(300), ws.next()).await
        else {
            continue;
        };
        match msg {
            Message::Text(t) => {
                let v: serde_json::Value = serde_json::from_str(t.as_str()).expect("JSON");
                if v["op"] != "advertise" {
                    continue;
                }
                for c in v["channels"].as_array().expect("channels") {
                    let topic = c["topic"].as_str().unwrap_or_default().to_string();
                    let schema = c["schemaName"].as_str().unwrap_or_default().to_string();
                    if !topic.starts_with("/robots/miro1/left/") {
                        continue;
                    }
                    let set = base64::engine::general_purpose::STANDARD
                        .decode(c["schema"].as_str().expect("schema"))
                        .expect("base64");
                    let pool = DescriptorPool::decode(set.as_slice()).expect("descriptors");
                    let desc = pool.get_message_by_name(&schema).expect("the type");
                    let id = c["id"].as_u64().expect("id");
                    wanted.insert(id, (topic, desc));
                    let sub = serde_json::json!({"op": "subscribe",
                        "subscriptions": [{"id": id, "channelId": id}]});
                    ws.send(Message::Text(sub.to_string().into()))
                        .await
                        .expect("subscribe");
                }
            }
            Message::Binary(b) => {
                let sub = u64::from(u32::from_le_bytes([b[1], b[2], b[3], b[4]]));
                let Some((topic, desc)) = wanted.get(&sub) else {
                    continue;
                };
                let m = DynamicMessage::decode(desc.clone(), &b[13..]).expect("decodes");
                if topic.ends_with("/image") {
                    let data = m.get_field_by_name("data").expect("data");
                    assert_eq!(
                        proto::jpeg_size_px(data.as_bytes().expect("bytes")),
                        Some((16, 9))
                    );
                } else {
                    let circles = m.get_field_by_name("circles").expect("circles");
                    assert_eq!(circles.as_list().map(<[_]>::len), Some(2));
                }
                got.insert(topic.clone());
            }
            _ => {}
        }
    }
    let _ = session.close().await;
    drop(server);
}
