//! Writes a few rendered camera frames to `out/render/` for a person to look at:
//! `cargo run -p sim --release --example render_frames`.

use proto::{HeadJoints, Pose2};
use sim::LensModel;
use sim::default_head;
use sim::{BallLook, BallPattern, Frame, Lighting, RobotBody, Scene};
use sim::{CameraRig, render_robot_cameras};
use sim::{Chessboard, calibration_views, render_chessboard};
use std::fs::File;
use std::io::BufWriter;
use std::path::Path;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let out = Path::new("out/render");
    std::fs::create_dir_all(out)?;
    let rig = CameraRig::new(LensModel::miro());
    let observer = Pose2 {
        x_m: -0.8,
        y_m: 0.0,
        theta_rad: 0.0,
    };
    let head = default_head();
    let mut scene = Scene {
        ball_m: Some([-0.35, 0.12, 0.04]),
        ..Scene::default()
    };
    save_pair(
        out,
        "near",
        &render_robot_cameras(&rig, &scene, observer, head, 1),
    )?;

    scene.ball_m = Some([0.9, -0.5, 0.04]);
    scene.robots = vec![RobotBody {
        pose: Pose2 {
            x_m: 0.1,
            y_m: -0.15,
            theta_rad: 2.5,
        },
        head: default_head(),
    }];
    save_pair(
        out,
        "far_robot",
        &render_robot_cameras(&rig, &scene, observer, head, 2),
    )?;

    let mut dim = scene.clone();
    dim.lighting = Lighting {
        exposure: 0.6,
        gain_rgb: [0.9, 1.0, 1.2],
        light_dir: [-0.5, -0.2, 0.6],
        ..Lighting::default()
    };
    dim.ball_look = BallLook {
        pattern: BallPattern::Patches,
        ..BallLook::default()
    };
    dim.ball_m = Some([-0.45, -0.1, 0.04]);
    save_pair(
        out,
        "dim_patches",
        &render_robot_cameras(&rig, &dim, observer, head, 3),
    )?;

    let corner = Pose2 {
        x_m: 1.4,
        y_m: 0.9,
        theta_rad: -2.6,
    };
    let up = HeadJoints {
        lift_rad: 0.25,
        yaw_rad: 0.4,
        pitch_rad: 0.05,
    };
    save_pair(
        out,
        "corner",
        &render_robot_cameras(&rig, &scene, corner, up, 4),
    )?;

    let lens = LensModel::miro();
    let board = Chessboard::default();
    for (k, pose) in calibration_views(&lens, 3, 1).iter().enumerate() {
        let (frame, corners) = render_chessboard(&lens, &board, pose, 2.0, k as u64);
        let path = out.join(format!("chessboard_{k}.png"));
        save_png(&path, &frame)?;
        let first = corners.as_ref().and_then(|c| c.first().copied());
        println!("{}: first inner corner at {first:?}", path.display());
    }
    Ok(())
}

fn save_pair(
    dir: &Path,
    name: &str,
    frames: &[(Frame, Option<sim::BallTruth>); 2],
) -> Result<(), Box<dyn std::error::Error>> {
    for ((frame, truth), side) in frames.iter().zip(["left", "right"]) {
        let path = dir.join(format!("{name}_{side}.png"));
        save_png(&path, frame)?;
        println!("{}: ball {:?}", path.display(), truth);
    }
    Ok(())
}

fn save_png(path: &Path, frame: &Frame) -> Result<(), Box<dyn std::error::Error>> {
    let mut enc = png::Encoder::new(
        BufWriter::new(File::create(path)?),
        frame.width,
        frame.height,
    );
    enc.set_color(png::ColorType::Rgb);
    enc.set_depth(png::BitDepth::Eight);
    enc.write_header()?.write_image_data(&frame.rgb)?;
    Ok(())
}
