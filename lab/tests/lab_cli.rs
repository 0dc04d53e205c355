//! The `ball-lab` binary as a process: `calibrate` on chessboard photographs and `train` on
//! patch folders.

#![allow(clippy::unwrap_used)]

use std::process::Command;

const BIN: &str = env!("CARGO_BIN_EXE_ball-lab");

#[test]
fn calibrate_writes_a_usable_calibration_from_photographs() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("left.toml");
    let photos = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../robot-agent/tests/data/chessboard-photos"
    );
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
        let mut disc = vision::RgbImage::filled(32, 32, [90, 110, 90]).unwrap();
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
        let png = |i: &vision::RgbImage| robot_agent::encode_png(i).unwrap();
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
    let m =
        vision::stages::svm::Model::from_json(&std::fs::read_to_string(&model).unwrap()).unwrap();
    assert_eq!(m.dim(), vision::stages::hog::HOG_LEN);
}
