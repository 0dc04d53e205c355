//! The project's forward pass against TF.js's own, on the squares and outputs recorded
//! once by `teacher/reference/reference.mjs` (its recipe is at its top).

use serde::Deserialize;
use std::collections::BTreeMap;
use std::path::Path;

#[derive(Deserialize)]
struct Reference {
    photos: BTreeMap<String, Photo>,
}

#[derive(Deserialize)]
struct Photo {
    levels: Vec<Level>,
}

#[derive(Deserialize)]
struct Level {
    cells: usize,
    ball: Vec<f32>,
    best: Vec<f32>,
    distances: Vec<Distances>,
}

#[derive(Deserialize)]
struct Distances {
    cell: usize,
    logits: Vec<f32>,
}

fn square(path: &Path) -> Vec<[u8; 3]> {
    let decoder = png::Decoder::new(std::io::BufReader::new(
        std::fs::File::open(path).expect("square opens"),
    ));
    let mut reader = decoder.read_info().expect("a PNG");
    let mut buf = vec![0; reader.output_buffer_size().expect("sized")];
    let info = reader.next_frame(&mut buf).expect("decodes");
    let channels = info.color_type.samples();
    buf[..info.buffer_size()]
        .chunks_exact(channels)
        .map(|p| [p[0], p[1], p[2]])
        .collect()
}

#[test]
fn the_forward_pass_matches_tfjs_on_real_photos() {
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data");
    let reference: Reference = serde_json::from_slice(
        &std::fs::read(data.join("reference.json")).expect("reference.json"),
    )
    .expect("reference parses");
    let teacher = teacher::Teacher::shipped().expect("the shipped teacher loads");
    assert_eq!(teacher.input_px(), 416);
    assert_eq!(reference.photos.len(), 3);
    for (name, photo) in &reference.photos {
        let sq = square(&data.join(format!("{name}.png")));
        let outputs = teacher.raw(&sq).expect("runs");
        assert_eq!(outputs.len(), 6);
        let mut worst_score = 0f32;
        let mut worst_logit = 0f32;
        for (l, level) in photo.levels.iter().enumerate() {
            let scores: Vec<f32> = outputs[l]
                .flatten_all()
                .and_then(|t| t.to_vec1())
                .expect("scores");
            let logits: Vec<f32> = outputs[l + 3]
                .flatten_all()
                .and_then(|t| t.to_vec1())
                .expect("logits");
            assert_eq!(scores.len(), level.cells * 80, "{name} level {l}");
            for c in 0..level.cells {
                let row = &scores[c * 80..(c + 1) * 80];
                let best = row.iter().copied().fold(0.0, f32::max);
                worst_score = worst_score
                    .max((row[teacher::SPORTS_BALL] - level.ball[c]).abs())
                    .max((best - level.best[c]).abs());
            }
            for d in &level.distances {
                for (k, want) in d.logits.iter().enumerate() {
                    worst_logit = worst_logit.max((logits[d.cell * 44 + k] - want).abs());
                }
            }
        }
        // Same float16 weights on both sides: only the order of float sums differs.
        assert!(
            worst_score < 2e-3,
            "{name}: a score differs by {worst_score}"
        );
        assert!(
            worst_logit < 2e-2,
            "{name}: a distance logit differs by {worst_logit}"
        );
    }
}

#[test]
fn the_teacher_finds_the_football_in_a_real_photo() {
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data");
    let sq = square(&data.join("messi5.png"));
    let teacher = teacher::Teacher::shipped().expect("loads");
    let balls: Vec<_> = teacher
        .detect_square(&sq, 0.3)
        .expect("runs")
        .into_iter()
        .filter(|d| d.class == teacher::SPORTS_BALL)
        .collect();
    assert!(!balls.is_empty(), "no ball found");
    let best = balls
        .iter()
        .max_by(|a, b| a.score.total_cmp(&b.score))
        .expect("one");
    // Our label of messi5.jpg (tests/data/real-balls), scaled by 416/548 into the square.
    let scale = 416.0 / 548.0;
    let label = [338.0 * scale, 289.0 * scale, 387.0 * scale, 336.0 * scale];
    assert!(
        teacher::iou(&best.box_px, &label) > 0.7,
        "{best:?} against {label:?}"
    );
}

#[test]
fn a_broken_teacher_file_says_what_is_wrong() {
    let truncated = &teacher::WEIGHTS[..teacher::WEIGHTS.len() / 2];
    let err = teacher::Teacher::from_safetensors(truncated).expect_err("truncated");
    assert!(err.to_string().contains("weights file"), "{err}");
    let err = teacher::Teacher::from_safetensors(b"").expect_err("empty");
    assert!(err.to_string().contains("weights file"), "{err}");
    // A photo of the wrong size is refused, not read past.
    let t = teacher::Teacher::shipped().expect("loads");
    let err = t
        .detect(&[0u8; 10], 4, 4, &teacher::Passes::quick(), 0.3)
        .expect_err("10 bytes are no 4x4 photo");
    assert!(err.to_string().contains("48"), "{err}");
}
