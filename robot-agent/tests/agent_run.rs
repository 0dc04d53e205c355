//! The `robot-agent` binary as a process: bad sources and files give clear errors,
//! `calibrate` on chessboard photographs and `train` on patch folders. (The agent on the
//! simulator's cameras, recorded and played back, and live over Zenoh, is the system tests'
//! `sim_agent` and its tests.)

#![allow(clippy::unwrap_used)]

use std::process::Command;

const BIN: &str = env!("CARGO_BIN_EXE_robot-agent");

#[test]
fn bad_sources_and_files_give_clear_errors() {
    let dir = tempfile::tempdir().unwrap();
    let run = |args: &[&str]| {
        let out = Command::new(BIN)
            .args(["run", "--robot-id", "miro1", "--offline"])
            .args(args)
            .output()
            .unwrap();
        assert!(!out.status.success());
        String::from_utf8_lossy(&out.stderr).into_owned()
    };
    assert!(
        run(&["--source", "camera:0"])
            .contains("is not images:DIR, mcap:FILE, ros1, zenoh:ros2 or zenoh:ros1")
    );
    let missing = format!("images:{}", dir.path().display());
    assert!(run(&["--source", &missing]).contains("frames.jsonl"));
    let garbage = dir.path().join("garbage.mcap");
    std::fs::write(&garbage, b"not an mcap file").unwrap();
    assert!(
        run(&["--source", &format!("mcap:{}", garbage.display())]).contains("not an MCAP file")
    );
    let bad_cal = dir.path().join("cal.toml");
    std::fs::write(&bad_cal, "model = 3").unwrap();
    assert!(
        run(&[
            "--source",
            &missing,
            "--calibration",
            bad_cal.to_str().unwrap()
        ])
        .contains("cal.toml")
    );
    // The simulator's cameras are the tools' (`sim_agent`), not a source of the product.
    assert!(run(&["--source", "sim"]).contains("is not images:DIR"));
}

#[test]
fn calibrate_writes_a_usable_calibration_from_photographs() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("left.toml");
    let photos = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/chessboard-photos");
    let run = Command::new(BIN)
        .args([
            "calibrate",
            "--images",
            photos,
            "--board",
            "9x6",
            "--square",
            "0.025",
        ])
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&run.stdout);
    assert!(run.status.success(), "{stdout}");
    assert!(stdout.contains("13 of 13 views used"), "{stdout}");
    let c =
        robot_agent::Calibration::from_toml_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    assert!(c.rms_px < 0.5, "{}", c.rms_px);
}

#[test]
fn train_fits_a_model_from_patch_folders() {
    let dir = tempfile::tempdir().unwrap();
    let (pos, neg) = (dir.path().join("pos"), dir.path().join("neg"));
    std::fs::create_dir_all(&pos).unwrap();
    std::fs::create_dir_all(&neg).unwrap();
    for k in 0..24u32 {
        // Shaded discs of varying size and offset against stripes of varying period.
        let r = 9.0 + f64::from(k % 5);
        let off = f64::from(k % 3) - 1.0;
        let mut disc = robot_agent::RgbImage::filled(32, 32, [90, 110, 90]).unwrap();
        let mut stripes = disc.clone();
        for y in 0..32u32 {
            for x in 0..32u32 {
                let (dx, dy) = (f64::from(x) - 15.5 - off, f64::from(y) - 15.5 + off);
                if dx.hypot(dy) <= r {
                    let shade = 0.6 + 0.4 * (1.0 - dy / r) / 2.0;
                    disc.set_pixel(x, y, [(240.0 * shade) as u8, (120.0 * shade) as u8, 30]);
                }
                if (x + k) / (3 + k % 4) % 2 == 0 {
                    stripes.set_pixel(x, y, [230, 120, 40]);
                }
            }
        }
        let png = |i: &robot_agent::RgbImage| robot_agent::encode_png(i).unwrap();
        std::fs::write(pos.join(format!("{k}.png")), png(&disc)).unwrap();
        std::fs::write(neg.join(format!("{k}.png")), png(&stripes)).unwrap();
    }
    let model = dir.path().join("model.json");
    let run = Command::new(BIN)
        .arg("train")
        .arg("--positives")
        .arg(&pos)
        .arg("--negatives")
        .arg(&neg)
        .arg("--out")
        .arg(&model)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&run.stdout);
    assert!(
        run.status.success(),
        "{stdout}{}",
        String::from_utf8_lossy(&run.stderr)
    );
    assert!(stdout.contains("precision"), "{stdout}");
    let m = robot_agent::SvmModel::from_json(&std::fs::read_to_string(&model).unwrap()).unwrap();
    assert_eq!(m.dim(), robot_agent::HOG_LEN);
}
