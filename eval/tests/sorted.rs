//! `evaluate --sorted DIR` end to end on real photos of the repo: the onboard photos of
//! `tests/data/msl-balls` as the folder with a ball, the held-out background photos of
//! `tests/data/backgrounds/heldout` as the one without. Every shipped detector gets its row,
//! the plot is drawn and the report's section written; a folder missing is refused by
//! name.

use std::path::{Path, PathBuf};
use std::process::Command;

fn repo(path: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join(path)
}

/// Copies every photo under `from` into `to`, flat.
fn copy_photos(from: &Path, to: &Path) -> usize {
    std::fs::create_dir_all(to).expect("folder");
    let mut n = 0;
    let mut stack = vec![from.to_path_buf()];
    while let Some(dir) = stack.pop() {
        for entry in std::fs::read_dir(&dir).expect("reads") {
            let path = entry.expect("entry").path();
            if path.is_dir() {
                stack.push(path);
            } else if path.extension().is_some_and(|e| e == "jpg" || e == "png") {
                let name = path.file_name().expect("name");
                std::fs::copy(&path, to.join(name)).expect("copies");
                n += 1;
            }
        }
    }
    n
}

#[test]
fn sorted_photos_are_scored_per_detector_into_their_section() {
    let dir = tempfile::tempdir().expect("temp dir");
    let sorted = dir.path().join("sorted");
    let with = copy_photos(&repo("tests/data/msl-balls"), &sorted.join("ball"));
    let without = copy_photos(
        &repo("tests/data/backgrounds/heldout"),
        &sorted.join("none"),
    );
    assert!(with >= 10 && without >= 5, "{with} {without}");
    let doc = dir.path().join("accuracy.md");
    std::fs::write(&doc, "# Report\n\nhand-written text\n").expect("doc");
    let plots = dir.path().join("plots");
    let out = Command::new(env!("CARGO_BIN_EXE_evaluate"))
        .arg("--sorted")
        .arg(&sorted)
        .args(["--with-ball", "ball", "--without-ball", "none"])
        .arg("--doc")
        .arg(&doc)
        .arg("--plots")
        .arg(&plots)
        .output()
        .expect("evaluate runs");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    let stdout = String::from_utf8_lossy(&out.stdout);
    // A row per shipped detector, the robot's first.
    let rows: Vec<&str> = stdout.lines().filter(|l| l.starts_with("| ")).collect();
    assert_eq!(rows.len(), 4, "{stdout}");
    assert!(rows[1].starts_with("| net |"), "{stdout}");
    assert!(stdout.contains("| two-stage |") && stdout.contains("| dissertation |"));
    // The robot's detector publishes a ball in most of the onboard photos with one (8 of
    // the 12 when its network was made; the floor leaves room for a retrained network,
    // not for a broken one). The background photos are no robot's view: it publishes a
    // false ball in most of them, which the table shows rather than hides.
    let cells: Vec<&str> = rows[1].split('|').map(str::trim).collect();
    let with_pct: f64 = cells[2].parse().expect("a share");
    assert!(with_pct >= 50.0, "{}", rows[1]);
    // The share of photos without a ball is reported as a number, not left out.
    assert!(cells[3].parse::<f64>().is_ok(), "{}", rows[1]);
    let png = std::fs::read(plots.join("sorted-sorted.png")).expect("the plot");
    assert_eq!(&png[1..4], b"PNG");
    let text = std::fs::read_to_string(&doc).expect("doc");
    assert!(text.contains("hand-written text"));
    assert!(text.contains("<!-- evaluate-sorted:begin -->"), "{text}");
    assert!(
        text.contains(&format!("{with} with a ball and {without} without")),
        "{text}"
    );

    // A folder that is not there is named, with what the command needs.
    let out = Command::new(env!("CARGO_BIN_EXE_evaluate"))
        .arg("--sorted")
        .arg(&sorted)
        .output()
        .expect("evaluate runs");
    assert!(!out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("Positive") && stderr.contains("--with-ball"),
        "{stderr}"
    );
}
