//! The scene's entities: what each thing of the match looks like in Foxglove's 3D panel.
//! Entity ids are stable (`robot/{id}`, `ball`, `prediction`, `sightings/accepted`,
//! `sightings/refused`, `pitch`), and each carries its numbers as metadata, which the panel
//! shows when the entity is clicked.

use super::draw::{ellipse, line, pose, pose_along, rgba, timestamp, vector};
use super::{PITCH_FRAME, SIGHTING_WINDOW_S, SceneInput};
use crate::engine::{RecentObs, RobotView};
use foxglove::messages::{
    ArrowPrimitive, Color, CubePrimitive, CylinderPrimitive, KeyValuePair, SceneEntity,
    SceneEntityDeletion, SceneUpdate, SpherePrimitive, TextPrimitive, scene_entity_deletion,
};
use proto::{BallState, BallStatus, Pitch, Stamp, WallSide};

const FLOOR: Color = rgba(0.20, 0.45, 0.22, 1.0);
const LINES: Color = rgba(0.95, 0.95, 0.95, 1.0);
const WALL: Color = rgba(0.85, 0.85, 0.80, 0.9);
const ROBOT: Color = rgba(0.15, 0.45, 0.90, 1.0);
/// Offline robots, as on the coach's page.
const OFFLINE: Color = rgba(0.62, 0.62, 0.62, 1.0);
const FOOTPRINT: Color = rgba(0.55, 0.75, 1.0, 0.8);
const ACCEPTED: Color = rgba(0.20, 0.85, 0.30, 1.0);
const REFUSED: Color = rgba(0.90, 0.15, 0.15, 1.0);
const BALL: Color = rgba(1.0, 0.55, 0.0, 1.0);
/// A ball not seen lately (coasting or lost).
const BALL_UNSEEN: Color = rgba(1.0, 0.55, 0.0, 0.45);
const PATH: Color = rgba(1.0, 0.85, 0.1, 1.0);
const PATH_BAND: Color = rgba(1.0, 0.85, 0.1, 0.45);
const BOUNCE: Color = rgba(1.0, 0.3, 0.9, 1.0);
const STOP: Color = rgba(1.0, 1.0, 1.0, 1.0);

const WALL_HEIGHT_M: f64 = 0.10;
const WALL_THICKNESS_M: f64 = 0.04;
/// A MiRo's body, drawn as an upright cylinder of this size.
const ROBOT_DIAMETER_M: f64 = 0.28;
const ROBOT_HEIGHT_M: f64 = 0.12;
/// The ellipses are drawn at 2σ.
const K_SIGMA: f64 = 2.0;
/// Lines are drawn just above the floor so that it does not hide them.
const LINE_Z_M: f64 = 0.005;

fn meta(pairs: &[(&str, String)]) -> Vec<KeyValuePair> {
    pairs
        .iter()
        .map(|(k, v)| KeyValuePair {
            key: (*k).into(),
            value: v.clone(),
        })
        .collect()
}

fn entity(id: &str, stamp: Stamp) -> SceneEntity {
    SceneEntity {
        timestamp: Some(timestamp(stamp)),
        frame_id: PITCH_FRAME.into(),
        id: id.into(),
        // No lifetime: an entity stays until the next update of its topic replaces it.
        lifetime: None,
        frame_locked: false,
        ..SceneEntity::default()
    }
}

fn text(x: f64, y: f64, z: f64, words: String, color: Color) -> TextPrimitive {
    TextPrimitive {
        pose: Some(pose(x, y, z, 0.0)),
        billboard: true,
        font_size: 14.0,
        scale_invariant: true,
        color: Some(color),
        text: words,
    }
}

fn arrow(
    from: [f64; 2],
    z: f64,
    direction: [f64; 2],
    length_m: f64,
    color: Color,
) -> ArrowPrimitive {
    let head = (0.3 * length_m).min(0.08);
    ArrowPrimitive {
        pose: Some(pose_along(from[0], from[1], z, direction)),
        shaft_length: (length_m - head).max(0.0),
        shaft_diameter: 0.015,
        head_length: head,
        head_diameter: 0.04,
        color: Some(color),
    }
}

fn sphere(at: [f64; 2], z: f64, diameter_m: f64, color: Color) -> SpherePrimitive {
    SpherePrimitive {
        pose: Some(pose(at[0], at[1], z, 0.0)),
        size: Some(vector(diameter_m, diameter_m, diameter_m)),
        color: Some(color),
    }
}

/// The pitch: the floor, its lines, and a low wall on each side that has one.
pub fn pitch(pitch: &Pitch, stamp: Stamp) -> SceneUpdate {
    let (hx, hy) = (pitch.length_m / 2.0, pitch.width_m / 2.0);
    let mut e = entity("pitch", stamp);
    e.cubes.push(CubePrimitive {
        pose: Some(pose(0.0, 0.0, -0.005, 0.0)),
        size: Some(vector(pitch.length_m + 0.2, pitch.width_m + 0.2, 0.01)),
        color: Some(FLOOR),
    });
    let outline = [[hx, hy], [-hx, hy], [-hx, -hy], [hx, -hy]];
    e.lines.push(line(&outline, LINE_Z_M, true, 0.02, LINES));
    e.lines
        .push(line(&[[0.0, hy], [0.0, -hy]], LINE_Z_M, false, 0.02, LINES));
    let r = 0.25 * pitch.width_m.min(pitch.length_m);
    let circle: Vec<[f64; 2]> = (0..48)
        .map(|i| {
            let t = std::f64::consts::TAU * f64::from(i) / 48.0;
            [r * t.cos(), r * t.sin()]
        })
        .collect();
    e.lines.push(line(&circle, LINE_Z_M, true, 0.02, LINES));
    let t = WALL_THICKNESS_M;
    for side in &pitch.walls {
        let (x, y, sx, sy) = match side {
            WallSide::XMax => (hx + t / 2.0, 0.0, t, pitch.width_m + 2.0 * t),
            WallSide::XMin => (-hx - t / 2.0, 0.0, t, pitch.width_m + 2.0 * t),
            WallSide::YMax => (0.0, hy + t / 2.0, pitch.length_m + 2.0 * t, t),
            WallSide::YMin => (0.0, -hy - t / 2.0, pitch.length_m + 2.0 * t, t),
        };
        e.cubes.push(CubePrimitive {
            pose: Some(pose(x, y, WALL_HEIGHT_M / 2.0, 0.0)),
            size: Some(vector(sx, sy, WALL_HEIGHT_M)),
            color: Some(WALL),
        });
    }
    e.metadata = meta(&[
        ("length_m", pitch.length_m.to_string()),
        ("width_m", pitch.width_m.to_string()),
        ("ball_radius_m", pitch.ball_radius_m.to_string()),
        ("wall_restitution", pitch.wall_restitution.to_string()),
    ]);
    SceneUpdate {
        deletions: vec![delete_all(stamp)],
        entities: vec![e],
    }
}

fn delete_all(stamp: Stamp) -> SceneEntityDeletion {
    SceneEntityDeletion {
        timestamp: Some(timestamp(stamp)),
        r#type: scene_entity_deletion::Type::All as i32,
        id: String::new(),
    }
}

/// Everything that moves. The update first deletes the topic's earlier entities, so a
/// robot that is gone from the engine is gone from the scene.
pub fn scene(input: &SceneInput) -> SceneUpdate {
    let mut entities: Vec<SceneEntity> = input
        .robots
        .iter()
        .filter_map(|r| robot(r, input.stamp))
        .collect();
    let recent: Vec<&RecentObs> = input
        .observations
        .iter()
        .filter(|o| input.stamp.secs_since(o.received) <= SIGHTING_WINDOW_S)
        .collect();
    entities.push(sightings(&recent, true, input.stamp));
    entities.push(sightings(&recent, false, input.stamp));
    if let Some(b) = input.ball {
        entities.push(ball(b, input.pitch.ball_radius_m, input.stamp));
        entities.push(prediction(b, input.stamp));
    }
    SceneUpdate {
        deletions: vec![delete_all(input.stamp)],
        entities,
    }
}

/// A robot with a pose: its body, heading, camera footprints and name; grey when offline.
fn robot(r: &RobotView, stamp: Stamp) -> Option<SceneEntity> {
    let p = r.pose?;
    let color = if r.online { ROBOT } else { OFFLINE };
    let mut e = entity(&format!("robot/{}", r.robot_id), stamp);
    e.cylinders.push(CylinderPrimitive {
        pose: Some(pose(p.x_m, p.y_m, ROBOT_HEIGHT_M / 2.0, p.theta_rad)),
        size: Some(vector(ROBOT_DIAMETER_M, ROBOT_DIAMETER_M, ROBOT_HEIGHT_M)),
        bottom_scale: 1.0,
        top_scale: 1.0,
        color: Some(color),
    });
    let heading = [p.theta_rad.cos(), p.theta_rad.sin()];
    e.arrows.push(arrow(
        [p.x_m, p.y_m],
        ROBOT_HEIGHT_M + 0.01,
        heading,
        0.25,
        color,
    ));
    if let Some(status) = &r.status {
        let footprint = if r.online { FOOTPRINT } else { OFFLINE };
        for f in &status.footprints {
            e.lines
                .push(line(&f.polygon_m, LINE_Z_M, true, 0.01, footprint));
        }
    }
    let label = if r.online {
        r.robot_id.clone()
    } else {
        format!("{} (offline)", r.robot_id)
    };
    e.texts
        .push(text(p.x_m, p.y_m, ROBOT_HEIGHT_M + 0.12, label, color));
    let opt = |v: Option<f64>| v.map_or_else(|| "-".into(), |v| format!("{v:.3}"));
    e.metadata = meta(&[
        ("online", r.online.to_string()),
        ("x_m", format!("{:.3}", p.x_m)),
        ("y_m", format!("{:.3}", p.y_m)),
        ("theta_rad", format!("{:.3}", p.theta_rad)),
        ("obs_rate_hz", format!("{:.1}", r.obs_rate_hz)),
        ("observations_accepted", r.observations_accepted.to_string()),
        ("observations_rejected", r.observations_rejected.to_string()),
        ("latency_s", opt(r.latency_s)),
        ("clock_offset_s", opt(r.clock_offset_s)),
        ("covariance_scale", opt(r.covariance_scale)),
    ]);
    Some(e)
}

/// The recent sightings, accepted or refused: a dot and a 2σ ellipse each.
fn sightings(recent: &[&RecentObs], accepted: bool, stamp: Stamp) -> SceneEntity {
    let (id, color) = if accepted {
        ("sightings/accepted", ACCEPTED)
    } else {
        ("sightings/refused", REFUSED)
    };
    let mut e = entity(id, stamp);
    let mut count = 0usize;
    for o in recent.iter().filter(|o| o.accepted == accepted) {
        if !(o.position_m[0].is_finite() && o.position_m[1].is_finite()) {
            continue;
        }
        count += 1;
        e.spheres.push(sphere(o.position_m, 0.02, 0.03, color));
        if let Some(points) = ellipse(o.position_m, o.covariance_m2, K_SIGMA) {
            e.lines.push(line(&points, LINE_Z_M, true, 0.006, color));
        }
        if let Some(reason) = o.reason {
            e.texts.push(text(
                o.position_m[0],
                o.position_m[1],
                0.08,
                format!("{}: {reason}", o.robot_id),
                color,
            ));
        }
    }
    e.metadata = meta(&[("count", count.to_string())]);
    e
}

/// The ball: a sphere, its 2σ position ellipse and its velocity (the arrow is as long as
/// a second's travel).
fn ball(b: &BallState, radius_m: f64, stamp: Stamp) -> SceneEntity {
    let mut e = entity("ball", stamp);
    let seen = matches!(b.status, BallStatus::Tracking | BallStatus::Stopped);
    let color = if seen { BALL } else { BALL_UNSEEN };
    e.spheres
        .push(sphere(b.position_m, radius_m, 2.0 * radius_m, color));
    let c = &b.covariance;
    if let Some(points) = ellipse(b.position_m, [c[0], c[1], c[4], c[5]], K_SIGMA) {
        e.lines.push(line(&points, LINE_Z_M, true, 0.012, color));
    }
    let v = b.velocity_mps;
    let speed = v[0].hypot(v[1]);
    if speed > 0.02 {
        e.arrows
            .push(arrow(b.position_m, radius_m, v, speed, color));
    }
    let status = serde_json::to_value(b.status)
        .ok()
        .and_then(|s| s.as_str().map(str::to_owned))
        .unwrap_or_default();
    e.texts.push(text(
        b.position_m[0],
        b.position_m[1],
        2.0 * radius_m + 0.05,
        format!("ball {speed:.2} m/s {status}"),
        color,
    ));
    e.metadata = meta(&[
        ("status", status),
        ("x_m", format!("{:.3}", b.position_m[0])),
        ("y_m", format!("{:.3}", b.position_m[1])),
        ("vx_mps", format!("{:.3}", v[0])),
        ("vy_mps", format!("{:.3}", v[1])),
        ("sigma_x_m", format!("{:.3}", c[0].max(0.0).sqrt())),
        ("sigma_y_m", format!("{:.3}", c[5].max(0.0).sqrt())),
        ("existence", format!("{:.2}", b.existence)),
        ("contributors", b.contributors.join(",")),
        ("decel_mps2", format!("{:.3}", b.model.rolling_decel_mps2)),
        (
            "wall_restitution",
            format!("{:.2}", b.model.wall_restitution),
        ),
    ]);
    e
}

/// The time between a path's samples (0.1 s when it has fewer than two).
fn sample_step_s(p: &proto::Prediction) -> f64 {
    match p.samples.as_slice() {
        [a, b, ..] if b.t_s > a.t_s => b.t_s - a.t_s,
        _ => 0.1,
    }
}

/// The predicted path with its 2σ ellipses, a marker at each bounce and a cross at the stop
/// point.
fn prediction(b: &BallState, stamp: Stamp) -> SceneEntity {
    let mut e = entity("prediction", stamp);
    let p = &b.prediction;
    let mut path: Vec<[f64; 2]> = vec![b.position_m];
    path.extend(p.samples.iter().map(|s| s.position_m));
    if let Some(stop) = &p.stop {
        path.push(stop.position_m);
    }
    path.retain(|q| q[0].is_finite() && q[1].is_finite());
    if path.len() >= 2 {
        e.lines.push(line(&path, 0.02, false, 0.015, PATH));
    }
    // How sure the path is: the 2σ ellipse of every half second's point and of the stop,
    // widening along the path.
    let every = ((0.5 / sample_step_s(p)).round() as usize).max(1);
    let mut widest_m: f64 = 0.0;
    let bands = p
        .samples
        .iter()
        .enumerate()
        .filter(|(k, _)| k % every == 0)
        .map(|(_, s)| (s.position_m, s.covariance_m2))
        .chain(p.stop.iter().map(|s| (s.position_m, s.covariance_m2)));
    for (at, cov) in bands {
        let Some(cov) = cov else { continue };
        if let Some(points) = ellipse(at, cov, K_SIGMA) {
            let major = points
                .iter()
                .map(|q| (q[0] - at[0]).hypot(q[1] - at[1]))
                .fold(0.0, f64::max);
            widest_m = widest_m.max(major);
            e.lines.push(line(&points, 0.015, true, 0.006, PATH_BAND));
        }
    }
    for bounce in &p.bounces {
        e.spheres
            .push(sphere(bounce.position_m, 0.04, 0.06, BOUNCE));
    }
    if let Some(stop) = &p.stop {
        let [x, y] = stop.position_m;
        let d = 0.05;
        e.lines.push(line(
            &[[x - d, y - d], [x + d, y + d]],
            0.02,
            false,
            0.015,
            STOP,
        ));
        e.lines.push(line(
            &[[x - d, y + d], [x + d, y - d]],
            0.02,
            false,
            0.015,
            STOP,
        ));
        e.texts
            .push(text(x, y, 0.1, format!("stop in {:.1} s", stop.t_s), STOP));
    }
    e.metadata = meta(&[
        ("horizon_s", format!("{:.2}", p.horizon_s)),
        ("samples", p.samples.len().to_string()),
        ("bounces", p.bounces.len().to_string()),
        ("widest_2sigma_radius_m", format!("{widest_m:.3}")),
        (
            "stop_s",
            p.stop
                .as_ref()
                .map_or_else(|| "-".into(), |s| format!("{:.2}", s.t_s)),
        ),
    ]);
    e
}
