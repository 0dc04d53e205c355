use super::*;

fn orange_share(photo: &SynthPhoto, label: &BallLabel) -> f64 {
    let [x0, y0, x1, y1] = label.box_px;
    let (mut orange, mut n) = (0usize, 0usize);
    for y in y0 as u32..=y1 as u32 {
        for x in x0 as u32..=x1 as u32 {
            let [r, g, b] = photo.frame.pixel(x, y);
            n += 1;
            orange += usize::from(r > g && g > b && r > 60);
        }
    }
    orange as f64 / n.max(1) as f64
}

#[test]
fn photos_are_reproducible_and_labelled_inside_the_frame() {
    for profile in [PhotoProfile::train(), PhotoProfile::heldout()] {
        let mut with_ball = 0;
        for i in 0..40 {
            let a = synth_photo(&profile, Background::Carpet, 7, i);
            let b = synth_photo(&profile, Background::Carpet, 7, i);
            assert_eq!(a, b, "photo {i} of {} differs between runs", profile.name);
            let (w, h) = (a.frame.width, a.frame.height);
            assert!(profile.sizes_px.contains(&(w, h)));
            assert_eq!(a.frame.rgb.len(), (3 * w * h) as usize);
            for ball in &a.balls {
                let [x0, y0, x1, y1] = ball.box_px;
                assert!(0.0 <= x0 && x0 < x1 && x1 <= f64::from(w - 1), "{:?}", ball);
                assert!(0.0 <= y0 && y0 < y1 && y1 <= f64::from(h - 1), "{:?}", ball);
                assert!(ball.radius_px >= profile.radius_px[0] * 0.99);
            }
            with_ball += a.balls.len();
            let q = a.jpeg_quality.expect("both profiles write JPEG");
            let [lo, hi] = profile.jpeg_quality.expect("quality range");
            assert!((lo..=hi).contains(&q));
        }
        // 40 photos at a 75–80 % ball chance.
        assert!((20..=38).contains(&with_ball), "{with_ball} balls");
    }
}

#[test]
fn a_big_ball_is_mostly_orange_inside_its_box() {
    let profile = PhotoProfile {
        radius_px: [30.0, 30.0],
        ball_chance: 1.0,
        distractors: [0, 0],
        occlusion_chance: 0.0,
        patches_chance: 0.0,
        white_balance_sigma: 0.0,
        exposure: [1.0, 1.0],
        gamma: [1.0, 1.0],
        noise_sigma: [0.0, 0.0],
        motion_blur_px: [0.0, 0.0],
        defocus_chance: 0.0,
        ..PhotoProfile::train()
    };
    let photo = synth_photo(&profile, Background::Carpet, 1, 0);
    let ball = photo.balls[0];
    // A disc fills π/4 of its box; clipping at the frame's edge only raises the share.
    let share = orange_share(&photo, &ball);
    assert!(share > 0.55, "{share}");
}

#[test]
fn a_picture_background_is_resized_to_the_output() {
    let picture = Frame {
        width: 50,
        height: 40,
        rgb: vec![90; 50 * 40 * 3],
    };
    let profile = PhotoProfile {
        ball_chance: 0.0,
        distractors: [0, 0],
        ..PhotoProfile::train()
    };
    let photo = synth_photo(&profile, Background::Picture(&picture), 3, 1);
    assert!(photo.balls.is_empty());
    assert!(
        profile
            .sizes_px
            .contains(&(photo.frame.width, photo.frame.height))
    );
}
