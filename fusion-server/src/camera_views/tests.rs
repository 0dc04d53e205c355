use super::images::{self, rejoin};
use super::*;
use crate::matchlog::read::LogMessage;
use foxglove::Decode;
use proto::test_support::camera_view;

const T0: Stamp = Stamp(1_700_000_000_000_000_000);

fn at(t_s: f64) -> Stamp {
    T0.offset_secs(t_s)
}

fn store() -> CameraViews {
    CameraViews::new(KeySpace::default(), ViewLimits::default())
}

fn key(robot: &str, camera: Camera) -> String {
    KeySpace::default()
        .robot_view(robot, camera)
        .unwrap_or_default()
}

fn payload(robot: &str, camera: Camera, t_s: f64) -> Vec<u8> {
    proto::encode(&camera_view(robot, camera, 0, at(t_s)))
}

#[test]
fn the_newest_view_of_each_camera_is_kept() {
    let mut s = store();
    for (t, camera) in [
        (0.0, Camera::Left),
        (0.5, Camera::Right),
        (1.0, Camera::Left),
    ] {
        let p = payload("miro1", camera, t);
        assert!(s.offer(&key("miro1", camera), &p, at(t)).is_ok());
    }
    let left = s.latest("miro1", Camera::Left).expect("a left view");
    assert_eq!(left.meta.stamp, at(1.0));
    assert!(left.meta.jpeg_base64.is_empty(), "the image is kept apart");
    assert_eq!(proto::jpeg_size_px(&left.jpeg), Some((16, 9)));
    let whole: CameraView = proto::decode(left.json.as_bytes()).expect("the payload as it came");
    assert!(!whole.jpeg_base64.is_empty());
    assert_eq!(s.all().len(), 2);
    assert_eq!(s.accepted(), 3);
    assert!(s.refused().is_empty());
}

#[test]
fn each_way_of_being_wrong_is_refused_with_its_reason() {
    let left = key("miro1", Camera::Left);
    let mut not_jpeg = camera_view("miro1", Camera::Left, 0, at(0.0));
    not_jpeg.jpeg_base64 = proto::jpeg_base64(b"\x89PNG\r\n\x1a\nnot a jpeg at all");
    let mut outside = camera_view("miro1", Camera::Left, 0, at(0.0));
    outside.candidates[0].u_px = 400.0;
    let cases: Vec<(String, Vec<u8>, &str)> = vec![
        (
            left.clone(),
            vec![b' '; MAX_VIEW_PAYLOAD_BYTES + 1],
            "too_large",
        ),
        (
            "rf/robots/miro1/view/middle".into(),
            payload("miro1", Camera::Left, 0.0),
            "bad_key",
        ),
        (
            "rf/robots/miro1/obs".into(),
            payload("miro1", Camera::Left, 0.0),
            "bad_key",
        ),
        (left.clone(), b"{ not json".to_vec(), "decode"),
        (
            left.clone(),
            payload("miro2", Camera::Left, 0.0),
            "wrong_robot",
        ),
        (
            left.clone(),
            payload("miro1", Camera::Right, 0.0),
            "wrong_camera",
        ),
        (left.clone(), proto::encode(&not_jpeg), "not_jpeg"),
        (left.clone(), proto::encode(&outside), "out_of_range"),
        (left.clone(), payload("miro1", Camera::Left, -60.0), "stamp"),
    ];
    for (k, p, reason) in cases {
        let mut s = store();
        let got = s.offer(&k, &p, at(0.0));
        assert_eq!(got.err().map(|e| e.reason()), Some(reason), "{k}");
        assert!(s.all().is_empty(), "nothing of a refused view is kept");
        assert_eq!(s.refused().get(reason), Some(&1));
    }
}

#[test]
fn an_older_view_does_not_replace_a_newer_one() {
    let mut s = store();
    let k = key("miro1", Camera::Left);
    assert!(
        s.offer(&k, &payload("miro1", Camera::Left, 1.0), at(1.0))
            .is_ok()
    );
    let old = s.offer(&k, &payload("miro1", Camera::Left, 0.5), at(1.1));
    assert_eq!(old.err(), Some(ViewRefusal::Stale));
    assert_eq!(
        s.latest("miro1", Camera::Left).map(|v| v.meta.stamp),
        Some(at(1.0))
    );
}

#[test]
fn a_flood_is_cut_to_the_rate_before_it_is_decoded() {
    let mut s = store();
    let k = key("flood", Camera::Left);
    // 1 000 views a second for two seconds.
    let mut kept = 0;
    for i in 0..2000 {
        let t = f64::from(i) * 0.001;
        if s.offer(&k, &payload("flood", Camera::Left, t), at(t))
            .is_ok()
        {
            kept += 1;
        }
    }
    let limits = ViewLimits::default();
    let most = (limits.burst + 2.0 * limits.rate_hz).ceil() as i32 + 1;
    assert!(
        kept <= most && kept >= most - 3,
        "{kept} kept, at most {most}"
    );
    assert!(s.refused()["rate_limited"] >= 1900);
    // Another robot is not held back by it.
    let other = key("miro2", Camera::Left);
    assert!(
        s.offer(&other, &payload("miro2", Camera::Left, 2.0), at(2.0))
            .is_ok()
    );
}

#[test]
fn the_cameras_kept_are_bounded() {
    let limits = ViewLimits {
        max_cameras: 4,
        ..ViewLimits::default()
    };
    let mut s = CameraViews::new(KeySpace::default(), limits);
    for i in 0..10 {
        let robot = format!("r{i}");
        let t = f64::from(i) * 0.1;
        let p = payload(&robot, Camera::Left, t);
        assert!(s.offer(&key(&robot, Camera::Left), &p, at(t)).is_ok());
    }
    let kept: Vec<String> = s.all().iter().map(|v| v.meta.robot_id.clone()).collect();
    assert_eq!(kept, ["r6", "r7", "r8", "r9"]);
}

#[test]
fn a_logged_view_is_rejoined_with_its_image() {
    let mut s = store();
    let k = key("miro1", Camera::Right);
    let v = s
        .offer(&k, &payload("miro1", Camera::Right, 0.2), at(0.25))
        .expect("kept");
    let mut messages: Vec<LogMessage> = images::records(&v)
        .into_iter()
        .map(|r| LogMessage {
            topic: r.topic,
            schema_name: r.schema.to_string(),
            log_time: at(0.25),
            publish_time: at(0.25),
            data: r.payload,
        })
        .collect();
    assert_eq!(messages[0].topic, "/robots/miro1/right/image");
    assert_eq!(messages[1].topic, "/robots/miro1/right/annotations");
    assert_eq!(messages[2].topic, k);
    let image =
        foxglove::messages::CompressedImage::decode(messages[0].data.as_slice()).expect("an image");
    assert_eq!(image.format, "jpeg");
    assert_eq!(image.data.as_ref(), &v.jpeg[..]);
    let marks = foxglove::messages::ImageAnnotations::decode(messages[1].data.as_slice())
        .expect("annotations");
    assert_eq!(marks.circles.len(), 2);
    assert_eq!(marks.circles[0].diameter, 4.0);
    assert_eq!(rejoin(&mut messages), 1);
    let whole: CameraView = proto::decode(&messages[2].data).expect("a view");
    let again = store().offer(&k, &proto::encode(&whole), at(0.3));
    assert!(again.is_ok(), "{again:?}");
}

#[test]
fn a_view_without_its_image_stays_as_it_is() {
    let mut v = camera_view("miro1", Camera::Left, 0, at(0.0));
    v.jpeg_base64.clear();
    let mut messages = vec![LogMessage {
        topic: key("miro1", Camera::Left),
        schema_name: images::VIEW_SCHEMA.into(),
        log_time: at(0.0),
        publish_time: at(0.0),
        data: proto::encode(&v),
    }];
    assert_eq!(rejoin(&mut messages), 0);
}
