#![allow(clippy::unwrap_used)]

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
        ..clean_profile(BallDesign::Plain)
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

/// A profile drawing one big unhidden ball of `design` per photo through an ideal camera
/// (the tone curve's random contrast aside).
fn clean_profile(design: BallDesign) -> PhotoProfile {
    PhotoProfile {
        sizes_px: &[(100, 100)],
        radius_px: [24.0, 24.0],
        ball_chance: 1.0,
        distractors: [0, 0],
        occlusion_chance: 0.0,
        held_chance: 0.0,
        designs: vec![(design, 1.0)],
        plain_neutral_chance: 0.0,
        white_balance_sigma: 0.0,
        exposure: [1.0, 1.0],
        gamma: [1.0, 1.0],
        noise_sigma: [0.0, 0.0],
        motion_blur_px: [0.0, 0.0],
        defocus_chance: 0.0,
        ..PhotoProfile::train()
    }
}

/// The pixels of the photo's ball within 85 % of its radius, from the first photos whose
/// ball lies wholly inside the frame (`count` of them), with the same photos' pixels
/// drawn without a ball.
fn inner_pixels(profile: &PhotoProfile, count: usize) -> Vec<([u8; 3], [u8; 3])> {
    let empty = PhotoProfile {
        ball_chance: 0.0,
        ..profile.clone()
    };
    let mut out = Vec::new();
    let mut found = 0;
    for i in 0..200 {
        let photo = synth_photo(profile, Background::Carpet, 11, i);
        let ball = photo.balls[0];
        let [x0, y0, x1, y1] = ball.box_px;
        let r = ball.radius_px;
        if x1 - x0 < 2.0 * r - 1e-9 || y1 - y0 < 2.0 * r - 1e-9 {
            continue;
        }
        let background = synth_photo(&empty, Background::Carpet, 11, i);
        let (cx, cy) = ((x0 + x1) / 2.0, (y0 + y1) / 2.0);
        for y in y0 as u32..=y1 as u32 {
            for x in x0 as u32..=x1 as u32 {
                if (f64::from(x) - cx).hypot(f64::from(y) - cy) < 0.85 * r {
                    out.push((photo.frame.pixel(x, y), background.frame.pixel(x, y)));
                }
            }
        }
        found += 1;
        if found == count {
            return out;
        }
    }
    panic!("fewer than {count} balls wholly inside their photos");
}

fn share(pixels: &[([u8; 3], [u8; 3])], test: impl Fn([u8; 3]) -> bool) -> f64 {
    pixels.iter().filter(|(p, _)| test(*p)).count() as f64 / pixels.len().max(1) as f64
}

fn bright(p: [u8; 3]) -> bool {
    p.iter().all(|&c| c > 110) && p.iter().max().unwrap() - p.iter().min().unwrap() < 40
}

fn dark(p: [u8; 3]) -> bool {
    p.iter().all(|&c| c < 50)
}

/// Hue in degrees and saturation of an 8-bit pixel.
fn hue_sat(p: [u8; 3]) -> (f64, f64) {
    let [r, g, b] = p.map(f64::from);
    let (max, min) = (r.max(g).max(b), r.min(g).min(b));
    if max - min < 1e-9 {
        return (0.0, 0.0);
    }
    let h = if max == r {
        60.0 * ((g - b) / (max - min)).rem_euclid(6.0)
    } else if max == g {
        60.0 * ((b - r) / (max - min) + 2.0)
    } else {
        60.0 * ((r - g) / (max - min) + 4.0)
    };
    (h, (max - min) / max)
}

#[test]
fn every_design_paints_a_ball_of_its_own_character() {
    for design in BallDesign::ALL {
        let mut profile = clean_profile(design);
        if design == BallDesign::Plain {
            // A saturated blue: nothing like the carpet.
            profile.hue_deg = [215.0, 225.0];
            profile.saturation = [0.85, 0.95];
        }
        let pixels = inner_pixels(&profile, 3);
        let changed = pixels
            .iter()
            .filter(|(p, bg)| p.iter().zip(bg).any(|(a, b)| a.abs_diff(*b) > 20))
            .count() as f64
            / pixels.len() as f64;
        assert!(
            changed > 0.9,
            "{}: {changed} of the ball differs",
            design.name()
        );
        let (light, black) = (share(&pixels, bright), share(&pixels, dark));
        let hued = |lo: f64, hi: f64, min_sat: f64| {
            move |p: [u8; 3]| {
                let (h, s) = hue_sat(p);
                (lo..=hi).contains(&h) && s >= min_sat
            }
        };
        let what = format!("{}: bright {light:.2}, dark {black:.2}", design.name());
        match design {
            BallDesign::Plain => {
                let blue = share(&pixels, hued(200.0, 240.0, 0.5));
                assert!(blue > 0.95, "{what}, blue {blue:.2}");
            }
            BallDesign::Patches => {
                let orange = share(&pixels, hued(0.0, 45.0, 0.3));
                assert!(orange > 0.6 && light > 0.03, "{what}, orange {orange:.2}");
            }
            BallDesign::Classic => {
                assert!(light > 0.3 && black > 0.1, "{what}");
            }
            BallDesign::WhiteBlackPanels => {
                assert!(light > 0.2 && black > 0.15, "{what}");
            }
            BallDesign::Modern => {
                let coloured = share(&pixels, |p| hue_sat(p).1 > 0.5);
                assert!(
                    light > 0.2 && coloured > 0.05,
                    "{what}, coloured {coloured:.2}"
                );
            }
            BallDesign::Yellow => {
                let yellow = share(&pixels, hued(35.0, 70.0, 0.45));
                let lines = share(&pixels, |p| p.iter().all(|&c| c < 90));
                assert!(
                    yellow > 0.7 && lines > 0.005,
                    "{what}, yellow {yellow:.2}, lines {lines:.3}"
                );
            }
        }
    }
}

#[test]
fn a_seed_gives_the_same_photo_for_every_design() {
    for design in BallDesign::ALL {
        let profile = small(PhotoProfile::train()).with_designs(&[design]);
        for i in 0..3 {
            let a = synth_photo(&profile, Background::Carpet, 5, i);
            let b = synth_photo(&profile, Background::Carpet, 5, i);
            assert_eq!(a, b, "{} photo {i}", design.name());
        }
        let a = synth_photo(&profile, Background::Carpet, 5, 0);
        let c = synth_photo(&profile, Background::Carpet, 6, 0);
        assert_ne!(
            a.frame,
            c.frame,
            "{}: another seed, another photo",
            design.name()
        );
    }
}

/// `profile` with a ball in every photo, and small photos for speed.
fn small(profile: PhotoProfile) -> PhotoProfile {
    PhotoProfile {
        sizes_px: &[(64, 48)],
        ball_chance: 1.0,
        ..profile
    }
}

#[test]
fn restricted_designs_are_the_only_ones_drawn() {
    let all = PhotoProfile::train();
    assert_eq!(all.drawn_designs(), BallDesign::ALL.to_vec());
    assert_eq!(
        PhotoProfile::heldout().drawn_designs(),
        BallDesign::ALL.to_vec()
    );
    for wanted in [
        vec![BallDesign::Classic],
        vec![BallDesign::Plain, BallDesign::Yellow, BallDesign::Plain],
    ] {
        let profile = small(PhotoProfile::heldout()).with_designs(&wanted);
        let mut seen = Vec::new();
        for i in 0..50 {
            for ball in synth_photo(&profile, Background::Carpet, 9, i).balls {
                assert!(wanted.contains(&ball.design), "{:?} drawn", ball.design);
                if !seen.contains(&ball.design) {
                    seen.push(ball.design);
                }
            }
        }
        seen.sort();
        let mut expected = wanted.clone();
        expected.sort();
        expected.dedup();
        assert_eq!(seen, expected);
    }
    // Every design but one: the held-out one never turns up, the others all do.
    let but_classic: Vec<BallDesign> = BallDesign::ALL
        .into_iter()
        .filter(|&d| d != BallDesign::Classic)
        .collect();
    let profile = small(all).with_designs(&but_classic);
    assert_eq!(profile.drawn_designs(), but_classic);
    let mut seen = Vec::new();
    for i in 0..50 {
        for ball in synth_photo(&profile, Background::Carpet, 9, i).balls {
            assert_ne!(ball.design, BallDesign::Classic);
            if !seen.contains(&ball.design) {
                seen.push(ball.design);
            }
        }
    }
    assert_eq!(seen.len(), but_classic.len(), "{seen:?}");
}

#[test]
fn designs_have_names_and_weights() {
    for design in BallDesign::ALL {
        assert_eq!(BallDesign::named(design.name()), Some(design));
    }
    assert_eq!(
        BallDesign::named(" White_Black_Panels "),
        Some(BallDesign::WhiteBlackPanels)
    );
    assert_eq!(BallDesign::named("striped"), None);
    let train = PhotoProfile::train();
    // Kept weights; a design the profile never draws gets the mean weight; none keeps all.
    let some = train.with_designs(&[BallDesign::Modern, BallDesign::Plain]);
    assert_eq!(
        some.designs,
        vec![(BallDesign::Modern, 0.1), (BallDesign::Plain, 0.35)]
    );
    let only_plain = PhotoProfile {
        designs: vec![(BallDesign::Plain, 2.0)],
        ..PhotoProfile::train()
    };
    assert_eq!(
        only_plain.with_designs(&[BallDesign::Yellow]).designs,
        vec![(BallDesign::Yellow, 2.0)]
    );
    assert_eq!(train.with_designs(&[]), train);
    // No positive weight: plain balls.
    let none = PhotoProfile {
        designs: Vec::new(),
        ball_chance: 1.0,
        ..PhotoProfile::train()
    };
    let photo = synth_photo(&none, Background::Carpet, 1, 0);
    assert_eq!(photo.balls[0].design, BallDesign::Plain);
}

#[test]
fn an_erased_box_takes_the_colour_around_it_and_nothing_else_changes() {
    let (w, h) = (80u32, 60u32);
    let mut frame = Frame {
        width: w,
        height: h,
        rgb: [40u8, 140, 50].repeat((w * h) as usize),
    };
    // A red disc of radius 8 at (40, 30): a real ball in a background photo.
    for y in 0..h {
        for x in 0..w {
            if (f64::from(x) - 40.0).hypot(f64::from(y) - 30.0) < 8.0 {
                let i = 3 * (y * w + x) as usize;
                frame.rgb[i..i + 3].copy_from_slice(&[220, 30, 20]);
            }
        }
    }
    let mut erased = frame.clone();
    crate::photo_shapes::erase_box(&mut erased, [32.0, 22.0, 48.0, 38.0]);
    // The disc is gone: the whole photo is the floor again.
    assert!(erased.rgb.chunks_exact(3).all(|p| p == [40, 140, 50]));
    // A box past the photo's corner is clipped; pixels beyond its border keep theirs.
    let mut corner = frame.clone();
    crate::photo_shapes::erase_box(&mut corner, [-10.0, -10.0, 5.0, 5.0]);
    crate::photo_shapes::erase_box(&mut corner, [70.0, 50.0, 95.0, 70.0]);
    for y in 12..48 {
        for x in 12..68 {
            let i = 3 * (y * w + x) as usize;
            assert_eq!(corner.rgb[i..i + 3], frame.rgb[i..i + 3], "({x}, {y})");
        }
    }
}

#[test]
fn a_held_ball_is_big_and_cut_by_the_bottom_edge() {
    let profile = PhotoProfile {
        held_chance: 1.0,
        ..clean_profile(BallDesign::Classic)
    };
    for i in 0..10 {
        let photo = synth_photo(&profile, Background::Carpet, 4, i);
        let [_, y0, _, y1] = photo.balls[0].box_px;
        let h = f64::from(photo.frame.height);
        assert!(photo.balls[0].radius_px >= 0.2 * h, "{:?}", photo.balls[0]);
        assert!(y1 >= h - 1.0 && y0 < 0.95 * h - 1.0, "{:?}", photo.balls[0]);
    }
}
