#![allow(clippy::unwrap_used)]
use super::*;

/// A grey-green floor with blotches and, when `r` is given, a ball of a random colour.
fn photo(rng: &mut Rng, w: u32, h: u32, ball: Option<([f64; 2], f64)>) -> (RgbImage, Vec<BallBox>) {
    let mut image = RgbImage::filled(w, h, [70, 110, 60]).unwrap();
    for _ in 0..6 {
        let (bx, by) = (rng.range(0.0, f64::from(w)), rng.range(0.0, f64::from(h)));
        for y in 0..h {
            for x in 0..w {
                if (f64::from(x) - bx).abs() < 12.0 && (f64::from(y) - by).abs() < 3.0 {
                    image.set_pixel(x, y, [230, 230, 230]);
                }
            }
        }
    }
    let mut balls = Vec::new();
    if let Some(([cx, cy], r)) = ball {
        let colour = [
            rng.range(150.0, 255.0) as u8,
            rng.range(0.0, 255.0) as u8,
            20,
        ];
        for y in 0..h {
            for x in 0..w {
                let d = (f64::from(x) - cx).hypot(f64::from(y) - cy);
                if d <= r {
                    let shade = 1.0 - 0.4 * d / r;
                    image.set_pixel(x, y, colour.map(|c| (f64::from(c) * shade) as u8));
                }
            }
        }
        balls.push(BallBox {
            x_min_px: cx - r,
            y_min_px: cy - r,
            x_max_px: cx + r,
            y_max_px: cy + r,
        });
    }
    (image, balls)
}

fn tiny() -> StageTrainConfig {
    StageTrainConfig {
        epochs: 1,
        batch: 2,
        learning_rate: 1e-3,
        weight_decay: 0.0,
        seed: 3,
    }
}

fn trained_pair() -> (TrainedStage, TrainedStage) {
    let mut rng = Rng::new(5);
    let photos: Vec<FramePhoto> = (0..3)
        .map(|k| {
            let (img, balls) = photo(
                &mut rng,
                320,
                200,
                Some(([60.0 + 50.0 * f64::from(k), 90.0], 9.0)),
            );
            FramePhoto::new(&img, &balls)
        })
        .collect();
    let heat = train_candidates(&photos, &photos[..1], &tiny(), None, &mut |_| {}).unwrap();
    let mut samples = Vec::new();
    for k in 0..4 {
        let (img, balls) = photo(
            &mut rng,
            160,
            120,
            Some(([80.0, 60.0], 10.0 + f64::from(k))),
        );
        let cfg = crate::training::ballnet_data::SampleConfig {
            window_over_radius: checker::WINDOW_OVER_RADIUS,
            ..Default::default()
        };
        samples.extend(
            crate::training::ballnet_data::photo_samples(&img, &balls, &[], &cfg, &mut rng).0,
        );
    }
    let check = train_checker(&samples, &samples[..4], &tiny(), None, &mut |_| {}).unwrap();
    (heat, check)
}

#[test]
fn the_agents_forward_passes_match_the_training_crates() {
    let (heat, check) = trained_pair();
    let (file, net, checker) = weights_file(&heat, &check, &BTreeMap::new()).unwrap();
    assert!(file.len() < 1_000_000, "{} bytes", file.len());
    let mut rng = Rng::new(9);
    let (img, _) = photo(&mut rng, 300, 170, Some(([100.0, 80.0], 12.0)));
    let (x, g) = candidates::input(&img);
    let (h, w) = (x.h, x.w);
    let mut chw = vec![0f32; 3 * h * w];
    for (i, px) in x.data.chunks_exact(3).enumerate() {
        for k in 0..3 {
            chw[k * h * w + i] = px[k];
        }
    }
    let patches: Vec<f32> = (0..3)
        .flat_map(|k| {
            let c = vision::Circle {
                center_px: [100.0 + 10.0 * f64::from(k), 80.0],
                radius_px: 12.0,
                score: 1.0,
            };
            checker::input(&checker::patch_for(&img, &c).unwrap())
        })
        .collect();
    let (want_heat, want_check) = candle_outputs(&heat, &check, (&chw, h, w), &patches).unwrap();
    let got_heat = net.forward(&x, g);
    assert_eq!(got_heat.values.len(), want_heat.len());
    for (a, b) in got_heat.values.iter().zip(&want_heat) {
        assert!((a - b).abs() < 1e-3 * (1.0 + b.abs()), "{a} vs {b}");
    }
    let got_check: Vec<f32> = checker
        .forward(&patches)
        .iter()
        .flat_map(|v| [v.logit, v.offset[0], v.offset[1], v.log_scale])
        .collect();
    assert_eq!(got_check.len(), want_check.len());
    for (a, b) in got_check.iter().zip(&want_check) {
        assert!((a - b).abs() < 1e-3 * (1.0 + b.abs()), "{a} vs {b}");
    }
}

#[test]
fn a_file_is_fine_tuned_from_and_bad_files_are_refused() {
    let (heat, check) = trained_pair();
    let (file, _, _) = weights_file(&heat, &check, &BTreeMap::new()).unwrap();
    let (h2, c2) = stages_of(&file).unwrap();
    assert_eq!(h2.tensors.len(), heat.tensors.len());
    assert_eq!(c2.tensors.len(), check.tensors.len());
    assert!(HeatNet::from_safetensors(&file[..file.len() / 2]).is_err());
    let old = robot_agent::builtin::BALLNET;
    let e = HeatNet::from_safetensors(old).unwrap_err();
    assert!(e.to_string().contains("format"), "{e}");
}

#[test]
fn photos_without_balls_or_bad_settings_are_refused() {
    let mut rng = Rng::new(1);
    let (img, balls) = photo(&mut rng, 100, 80, None);
    let photos = vec![FramePhoto::new(&img, &balls)];
    assert!(matches!(
        train_candidates(&photos, &[], &tiny(), None, &mut |_| {}),
        Err(DetectorTrainError::NoData(_))
    ));
    let bad = StageTrainConfig {
        epochs: 0,
        ..tiny()
    };
    assert!(matches!(
        train_checker(&[], &[], &bad, None, &mut |_| {}),
        Err(DetectorTrainError::Settings(_))
    ));
}

#[test]
fn a_crops_ball_cell_is_where_the_ball_is() {
    let mut rng = Rng::new(11);
    for k in 0..20 {
        let (w, h) = (if k % 2 == 0 { 640 } else { 480 }, 400);
        let c = [rng.range(40.0, f64::from(w) - 40.0), rng.range(40.0, 360.0)];
        let r = rng.range(4.0, 30.0);
        let (img, balls) = photo(&mut rng, w, h, Some((c, r)));
        let p = FramePhoto::new(&img, &balls);
        for augment in [false, true] {
            let crop = crop(&p, &mut rng, augment);
            let (rows, cols) = (CROP_H / CELL_PX, CROP_W / CELL_PX);
            let Some(i) = crop.label.iter().position(|&l| l > 0.0) else {
                continue;
            };
            let (row, col) = (i / cols, i % cols);
            assert_eq!(crop.reg[i], 1.0);
            assert_eq!(crop.weight[i], 1.0);
            let cx = candidates::cell_centre_px(col) + f64::from(crop.target[i]) * CELL_PX as f64;
            let cy = candidates::cell_centre_px(row)
                + f64::from(crop.target[rows * cols + i]) * CELL_PX as f64;
            // The ball is the frame's most colourful thing: its centre pixel stands far
            // from the crop's mean in some channel.
            let (x, y) = (cx as usize, cy as usize);
            let v: Vec<f32> = (0..3)
                .map(|ch| crop.input[ch * CROP_W * CROP_H + y * CROP_W + x])
                .collect();
            let spread = v.iter().map(|a| a.abs()).fold(0f32, f32::max);
            assert!(
                spread > 0.8,
                "k {k} augment {augment}: {v:?} at ({cx:.1}, {cy:.1})"
            );
        }
    }
}
