use super::*;
use crate::engine::EngineConfig;
use foxglove::Decode;
use foxglove::messages::SceneEntity;
use proto::test_support::observation;
use proto::{Observation, Pose2};

const T0: u64 = 1_800_000_000_000_000_000;

fn at(t_s: f64) -> Stamp {
    Stamp(T0).offset_secs(t_s)
}

/// An engine that has seen a ball rolling along +x from two robots; `miro2` then left.
fn engine() -> Engine {
    let mut e = Engine::new(EngineConfig::default());
    for k in 0..30u64 {
        let t = k as f64 / 15.0;
        for (robot, pose) in [("miro1", (-1.0, 0.5, 0.0)), ("miro2", (1.0, -0.5, 3.0))] {
            let o = Observation {
                robot_pose: Pose2 {
                    x_m: pose.0,
                    y_m: pose.1,
                    theta_rad: pose.2,
                },
                ..observation(robot, k, at(t), [0.3 * t, 0.2])
            };
            let r = e.observation(Some(robot), &proto::encode(&o), at(t + 0.02));
            assert!(r.is_ok(), "{r:?}");
        }
    }
    e.liveliness("miro1", true, at(0.0)).expect("id");
    e.liveliness("miro2", true, at(0.0)).expect("id");
    e.liveliness("miro2", false, at(1.5)).expect("id");
    // One refused: far off the pitch.
    let far = observation("miro1", 99, at(1.95), [40.0, 0.0]);
    assert!(
        e.observation(Some("miro1"), &proto::encode(&far), at(1.96))
            .is_err()
    );
    e
}

fn decode(records: &[SceneRecord], topic: &str) -> Vec<u8> {
    records
        .iter()
        .find(|r| r.topic == topic)
        .unwrap_or_else(|| panic!("no {topic} in {records:?}"))
        .payload
        .clone()
}

fn find<'a>(update: &'a SceneUpdate, id: &str) -> &'a SceneEntity {
    update
        .entities
        .iter()
        .find(|e| e.id == id)
        .unwrap_or_else(|| panic!("no entity {id}"))
}

fn position(p: &Option<foxglove::messages::Pose>) -> [f64; 2] {
    let v = p
        .as_ref()
        .and_then(|p| p.position.as_ref())
        .expect("a position");
    [v.x, v.y]
}

#[test]
fn the_scene_holds_the_pitch_the_robots_the_sightings_and_the_ball_where_they_are() {
    let e = engine();
    let now = at(2.0);
    let ball = e.ball_state(now).expect("a ball");
    let records = Scene::new().tick(&e, now, Some(&ball));
    let topics: Vec<_> = records.iter().map(|r| r.topic).collect();
    assert_eq!(topics, [PITCH_TOPIC, TRANSFORMS_TOPIC, SCENE_TOPIC]);

    let pitch = SceneUpdate::decode(decode(&records, PITCH_TOPIC).as_slice()).expect("decodes");
    let p = find(&pitch, "pitch");
    assert_eq!(p.frame_id, PITCH_FRAME);
    // The floor and four walls; the outline's corners at the pitch's half sizes.
    assert_eq!(p.cubes.len(), 5);
    let corners = &p.lines[0].points;
    assert!(
        corners
            .iter()
            .all(|c| (c.x.abs() - 1.95).abs() < 1e-9 && (c.y.abs() - 1.3).abs() < 1e-9)
    );

    let scene = SceneUpdate::decode(decode(&records, SCENE_TOPIC).as_slice()).expect("decodes");
    assert_eq!(scene.deletions.len(), 1, "earlier entities are replaced");
    let m1 = find(&scene, "robot/miro1");
    assert_eq!(position(&m1.cylinders[0].pose), [-1.0, 0.5]);
    let colour = |e: &SceneEntity| e.cylinders[0].color.expect("a colour");
    assert!(colour(m1).b > 0.8 && colour(m1).r < 0.3, "online is blue");
    let m2 = find(&scene, "robot/miro2");
    assert_eq!(position(&m2.cylinders[0].pose), [1.0, -0.5]);
    let grey = colour(m2);
    assert!(grey.r == grey.g && grey.g == grey.b, "offline is grey");
    assert!(m2.texts[0].text.contains("offline"));

    let b = find(&scene, "ball");
    let drawn = position(&b.spheres[0].pose);
    assert!(
        (drawn[0] - ball.position_m[0]).abs() < 1e-9
            && (drawn[1] - ball.position_m[1]).abs() < 1e-9
    );
    assert!((drawn[0] - 0.58).abs() < 0.1, "{drawn:?}");
    assert_eq!(b.lines.len(), 1, "the 2σ ellipse");
    assert_eq!(b.arrows.len(), 1, "the velocity");
    let pred = find(&scene, "prediction");
    assert!(pred.lines[0].points.len() >= 2);
    // The fused ball's path carries covariances: its 2σ ellipses are drawn, closed.
    let bands = pred.lines.iter().filter(|l| l.r#type == 1).count();
    assert!(bands >= 2, "{bands} ellipses along the path");
    let widest = pred
        .metadata
        .iter()
        .find(|kv| kv.key == "widest_2sigma_radius_m")
        .and_then(|kv| kv.value.parse::<f64>().ok())
        .expect("the widest ellipse in the metadata");
    assert!(widest > 0.0);

    let accepted = find(&scene, "sightings/accepted");
    let refused = find(&scene, "sightings/refused");
    assert!(!accepted.spheres.is_empty());
    assert_eq!(refused.spheres.len(), 1);
    assert_eq!(position(&refused.spheres[0].pose), [40.0, 0.0]);
    assert!(refused.texts[0].text.starts_with("miro1: "));

    let tf =
        FrameTransforms::decode(decode(&records, TRANSFORMS_TOPIC).as_slice()).expect("decodes");
    let names: Vec<_> = tf
        .transforms
        .iter()
        .map(|t| t.child_frame_id.as_str())
        .collect();
    assert_eq!(names, ["miro1", "miro2"]);
    assert!(
        tf.transforms
            .iter()
            .all(|t| t.parent_frame_id == PITCH_FRAME)
    );
}

#[test]
fn updates_are_paced_and_the_pitch_repeats_every_second() {
    let e = engine();
    let mut scene = Scene::new();
    let mut counts = std::collections::BTreeMap::<&str, usize>::new();
    // Two seconds of ticks at 30 Hz.
    for k in 0..60 {
        let t = at(2.0 + f64::from(k) / 30.0);
        for r in scene.tick(&e, t, e.ball_state(t).as_ref()) {
            *counts.entry(r.topic).or_default() += 1;
        }
    }
    assert_eq!(counts[SCENE_TOPIC], 20);
    assert_eq!(counts[TRANSFORMS_TOPIC], 20);
    assert_eq!(counts[PITCH_TOPIC], 2);
    // A replay that seeks back starts over at once.
    assert!(!scene.tick(&e, at(1.0), None).is_empty());
}

#[test]
fn without_a_ball_the_scene_has_no_ball_and_bad_numbers_draw_nothing() {
    let mut e = Engine::new(EngineConfig::default());
    e.liveliness("miro1", true, at(0.0)).expect("id");
    let records = Scene::new().tick(&e, at(0.5), None);
    let scene = SceneUpdate::decode(decode(&records, SCENE_TOPIC).as_slice()).expect("decodes");
    assert!(
        scene
            .entities
            .iter()
            .all(|e| e.id != "ball" && e.id != "prediction")
    );
    // A robot without a pose yet is not drawn (nowhere to draw it).
    assert!(scene.entities.iter().all(|e| !e.id.starts_with("robot/")));
}

#[test]
fn the_schemas_are_foxglove_s_protobuf_descriptors() {
    let s = schemas();
    let names: Vec<_> = s.iter().map(|s| s.name.as_str()).collect();
    assert_eq!(names, [SCENE_SCHEMA, TRANSFORMS_SCHEMA]);
    assert!(s.iter().all(|s| s.encoding == "protobuf"
        && s.message_encoding == "protobuf"
        && !s.data.is_empty()));
    assert!(is_scene_schema(SCENE_SCHEMA) && !is_scene_schema("BallState"));
}

#[test]
fn the_foxglove_layout_in_the_docs_opens_on_this_scene() {
    let text = include_str!("../../../docs/foxglove/match-layout.json");
    let layout: serde_json::Value = serde_json::from_str(text).expect("the layout is JSON");
    let three_d = &layout["configById"]["3D!match"];
    assert_eq!(three_d["followTf"], PITCH_FRAME);
    for topic in [SCENE_TOPIC, PITCH_TOPIC] {
        assert_eq!(three_d["topics"][topic]["visible"], true, "{topic}");
    }
    let state = format!(
        "\"{}\"",
        proto::KeySpace::new(proto::DEFAULT_PREFIX)
            .expect("prefix")
            .ball_state()
    );
    assert!(
        text.contains(&state.replace('"', "\\\"")),
        "plots the ball state"
    );
    // A robot's two cameras, each with its annotations.
    for camera in [proto::Camera::Left, proto::Camera::Right] {
        let v = proto::test_support::camera_view("miro1", camera, 0, Stamp(0));
        let image = &layout["configById"][format!("Image!{}", proto::camera_chunk(camera))];
        let mode = &image["imageMode"];
        assert_eq!(
            mode["imageTopic"],
            crate::camera_views::images::image_topic(&v)
        );
        let annotations = crate::camera_views::images::annotations_topic(&v);
        assert_eq!(mode["annotations"][annotations]["visible"], true);
    }
}
