//! Tests of the camera models: known values, round trips over the whole image, the
//! analytic Jacobian against central differences, and garbage inputs.

#![allow(clippy::unwrap_used)]

use super::*;
use approx::assert_relative_eq;
use proptest::prelude::*;

/// A 640×480 webcam with strong barrel distortion.
fn webcam() -> CameraModel {
    CameraModel {
        intrinsics: Intrinsics {
            fx_px: 500.0,
            fy_px: 505.0,
            cx_px: 319.5,
            cy_px: 239.5,
            width_px: 640,
            height_px: 480,
        },
        distortion: Distortion::BrownConrady {
            k1: -0.3,
            k2: 0.1,
            p1: 0.001,
            p2: -0.002,
            k3: 0.0,
        },
    }
}

/// A 640×360 fisheye with about 120° of horizontal field of view.
fn fisheye() -> CameraModel {
    CameraModel {
        intrinsics: Intrinsics {
            fx_px: 300.0,
            fy_px: 300.0,
            cx_px: 320.0,
            cy_px: 180.0,
            width_px: 640,
            height_px: 360,
        },
        distortion: Distortion::KannalaBrandt {
            k1: -0.02,
            k2: 0.005,
            k3: -0.001,
            k4: 0.0,
        },
    }
}

fn models() -> [CameraModel; 2] {
    [webcam(), fisheye()]
}

/// Pixels every 8 px across the image, both borders included.
fn pixel_grid(model: &CameraModel) -> Vec<[f64; 2]> {
    let w = f64::from(model.intrinsics.width_px);
    let h = f64::from(model.intrinsics.height_px);
    let steps = |extent: f64| {
        let n = (extent / 8.0).ceil() as usize;
        (0..=n).map(move |k| -0.5 + extent * k as f64 / n as f64)
    };
    steps(w)
        .flat_map(|u| steps(h).map(move |v| [u, v]))
        .collect()
}

fn angle_between_rad(a: [f64; 3], b: [f64; 3]) -> f64 {
    let cross = [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ];
    let dot = a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    cross[0].hypot(cross[1]).hypot(cross[2]).atan2(dot)
}

#[test]
fn realistic_models_pass_the_check() {
    for model in models() {
        assert_eq!(model.check(), Ok(()));
    }
}

#[test]
fn check_rejects_bad_parameters() {
    let mut model = webcam();
    model.intrinsics.fy_px = 0.0;
    assert!(matches!(
        model.check(),
        Err(CameraModelError::NonPositiveFocalLength { field: "fy_px", .. })
    ));
    model.intrinsics.fy_px = f64::NAN;
    assert!(matches!(
        model.check(),
        Err(CameraModelError::NonPositiveFocalLength { field: "fy_px", .. })
    ));
    model.intrinsics.fy_px = f64::INFINITY;
    assert_eq!(
        model.check(),
        Err(CameraModelError::NonFinite { field: "fy_px" })
    );

    let mut model = webcam();
    model.intrinsics.cx_px = f64::NAN;
    assert_eq!(
        model.check(),
        Err(CameraModelError::NonFinite { field: "cx_px" })
    );

    let mut model = fisheye();
    model.distortion = Distortion::KannalaBrandt {
        k1: 0.0,
        k2: 0.0,
        k3: f64::NEG_INFINITY,
        k4: 0.0,
    };
    assert_eq!(
        model.check(),
        Err(CameraModelError::NonFinite { field: "k3" })
    );

    let mut model = webcam();
    model.intrinsics.height_px = 0;
    assert!(matches!(
        model.check(),
        Err(CameraModelError::ZeroImageSize { height_px: 0, .. })
    ));
}

#[test]
fn zero_distortion_is_the_plain_pinhole() {
    let model = CameraModel {
        distortion: Distortion::NONE,
        ..webcam()
    };
    let [u, v] = model.project([0.3, -0.2, 2.0]).unwrap();
    assert_relative_eq!(u, 319.5 + 500.0 * 0.15, max_relative = 1e-15);
    assert_relative_eq!(v, 239.5 - 505.0 * 0.1, max_relative = 1e-15);
    let [x, y] = model.undistort_point([u, v]).unwrap();
    assert_relative_eq!(x, 0.15, max_relative = 1e-15);
    assert_relative_eq!(y, -0.1, max_relative = 1e-15);
}

#[test]
fn zero_fisheye_distortion_is_equidistant() {
    let model = CameraModel {
        distortion: Distortion::KannalaBrandt {
            k1: 0.0,
            k2: 0.0,
            k3: 0.0,
            k4: 0.0,
        },
        ..fisheye()
    };
    // 45° off-axis, straight right.
    let [u, v] = model.project([1.0, 0.0, 1.0]).unwrap();
    assert_relative_eq!(
        u,
        320.0 + 300.0 * std::f64::consts::FRAC_PI_4,
        max_relative = 1e-15
    );
    assert_relative_eq!(v, 180.0, max_relative = 1e-15);
}

#[test]
fn brown_conrady_hand_computed_point() {
    // x = 0.2, y = 0.1: r² = 0.05, radial = 1 − 0.3·0.05 + 0.1·0.0025 = 0.98525;
    // x_d = 0.197050 + 2·0.001·0.02 − 0.002·(0.05 + 0.08) = 0.196830,
    // y_d = 0.098525 + 0.001·(0.05 + 0.02) − 2·0.002·0.02 = 0.098515.
    let [u, v] = webcam().project([0.4, 0.2, 2.0]).unwrap();
    assert_relative_eq!(u, 319.5 + 500.0 * 0.19683, max_relative = 1e-14);
    assert_relative_eq!(v, 239.5 + 505.0 * 0.098515, max_relative = 1e-14);
}

#[test]
fn kannala_brandt_hand_computed_point() {
    // θ = π/4: θ_d = θ (1 − 0.02 θ² + 0.005 θ⁴ − 0.001 θ⁶) = 0.777018594607892.
    let [u, v] = fisheye().project([1.0, 0.0, 1.0]).unwrap();
    assert_relative_eq!(u, 320.0 + 300.0 * 0.777018594607892, max_relative = 1e-14);
    assert_relative_eq!(v, 180.0, max_relative = 1e-14);
    // Off both axes: ρ = 0.5, θ = atan2(0.5, 1.2), the same polynomial along (0.6, −0.8).
    let [u, v] = fisheye().project([0.3, -0.4, 1.2]).unwrap();
    assert_relative_eq!(u, 390.8492480939675, max_relative = 1e-14);
    assert_relative_eq!(v, 85.53433587471, max_relative = 1e-12);
}

#[test]
fn the_principal_point_is_the_optical_axis() {
    for model in models() {
        let i = model.intrinsics;
        let ray = model.unproject([i.cx_px, i.cy_px]).unwrap();
        assert_eq!(ray, [0.0, 0.0, 1.0]);
        let [u, v] = model.project([0.0, 0.0, 3.0]).unwrap();
        assert_eq!([u, v], [i.cx_px, i.cy_px]);
    }
}

#[test]
fn pixels_round_trip_over_the_whole_image() {
    for model in models() {
        for pixel in pixel_grid(&model) {
            let ray = model.unproject(pixel).unwrap();
            assert_relative_eq!(ray[0].hypot(ray[1]).hypot(ray[2]), 1.0, epsilon = 1e-15);
            assert!(ray[2] > 0.0);
            for depth_m in [0.05, 1.0, 40.0] {
                let back = model
                    .project([ray[0] * depth_m, ray[1] * depth_m, ray[2] * depth_m])
                    .unwrap();
                let error_px = (back[0] - pixel[0]).hypot(back[1] - pixel[1]);
                assert!(error_px < 1e-9, "{model:?} {pixel:?}: {error_px} px");
            }
            let [x, y] = model.undistort_point(pixel).unwrap();
            assert!(angle_between_rad([x, y, 1.0], ray) < 1e-12);
        }
    }
}

#[test]
fn rays_round_trip_over_the_whole_field_of_view() {
    for model in models() {
        let mut in_image = 0;
        for a in 0..=90 {
            let theta_rad = f64::from(a).to_radians() * 0.95;
            for b in 0..72 {
                let phi_rad = f64::from(b).to_radians() * 5.0;
                let ray = [
                    theta_rad.sin() * phi_rad.cos(),
                    theta_rad.sin() * phi_rad.sin(),
                    theta_rad.cos(),
                ];
                let Some(pixel) = model.project(ray) else {
                    continue;
                };
                if !model.intrinsics.contains(pixel) {
                    continue;
                }
                in_image += 1;
                let back = model.unproject(pixel).unwrap();
                let error_rad = angle_between_rad(ray, back);
                assert!(error_rad < 1e-9, "{model:?} {ray:?}: {error_rad} rad");
            }
        }
        assert!(in_image > 1000, "only {in_image} rays land on the image");
    }
}

#[test]
fn the_fisheye_sees_about_120_degrees_across() {
    let model = fisheye();
    let left = model.unproject([-0.5, 180.0]).unwrap();
    let right = model.unproject([639.5, 180.0]).unwrap();
    let fov_deg = angle_between_rad(left, right).to_degrees();
    assert!((115.0..125.0).contains(&fov_deg), "{fov_deg}°");
}

/// Central differences of `project`, with a step relative to the point's size.
fn numeric_jacobian(model: &CameraModel, p: [f64; 3]) -> [[f64; 3]; 2] {
    let h = 1e-6 * p[0].hypot(p[1]).hypot(p[2]);
    let mut j = [[0.0; 3]; 2];
    for col in 0..3 {
        let mut plus = p;
        let mut minus = p;
        plus[col] += h;
        minus[col] -= h;
        let a = model.project(plus).unwrap();
        let b = model.project(minus).unwrap();
        for row in 0..2 {
            j[row][col] = (a[row] - b[row]) / (2.0 * h);
        }
    }
    j
}

#[test]
fn jacobian_matches_central_differences() {
    for model in models() {
        for pixel in pixel_grid(&model).into_iter().step_by(7) {
            let ray = model.unproject(pixel).unwrap();
            for depth_m in [0.3, 2.5] {
                let p = ray.map(|c| c * depth_m);
                let analytic = model.project_jacobian(p).unwrap();
                let numeric = numeric_jacobian(&model, p);
                let scale = analytic
                    .iter()
                    .flatten()
                    .fold(0.0_f64, |m, v| m.max(v.abs()));
                for (a, n) in analytic.iter().flatten().zip(numeric.iter().flatten()) {
                    assert!((a - n).abs() <= 1e-6 * scale, "{model:?} {p:?}: {a} vs {n}");
                }
            }
        }
    }
}

#[test]
fn fisheye_jacobian_is_continuous_at_the_axis() {
    let model = fisheye();
    let on_axis = model.project_jacobian([0.0, 0.0, 2.0]).unwrap();
    let near_axis = model.project_jacobian([1e-6, -2e-6, 2.0]).unwrap();
    let off_axis = model.project_jacobian([1e-4, -2e-4, 2.0]).unwrap();
    let scale = 300.0 / 2.0;
    for ((a, b), c) in on_axis
        .iter()
        .flatten()
        .zip(near_axis.iter().flatten())
        .zip(off_axis.iter().flatten())
    {
        assert!((a - b).abs() < 1e-5 * scale, "{a} vs {b}");
        assert!((a - c).abs() < 1e-3 * scale, "{a} vs {c}");
    }
}

#[test]
fn points_behind_the_camera_have_no_pixel() {
    for model in models() {
        for p in [
            [0.0, 0.0, 0.0],
            [0.1, 0.2, 0.0],
            [0.0, 0.0, -1.0],
            [3.0, 1.0, -0.01],
        ] {
            assert_eq!(model.project(p), None);
            assert_eq!(model.project_jacobian(p), None);
        }
    }
}

#[test]
fn the_fisheye_projects_up_to_just_under_90_degrees() {
    let model = fisheye();
    let theta_rad = 89.9_f64.to_radians();
    let ray = [theta_rad.sin(), 0.0, theta_rad.cos()];
    let pixel = model.project(ray).unwrap();
    assert!(!model.intrinsics.contains(pixel));
    let back = model.unproject(pixel).unwrap();
    assert!(angle_between_rad(ray, back) < 1e-9);
    // Exactly 90° (z = 0) is not in front of the camera.
    assert_eq!(model.project([1.0, 0.0, 0.0]), None);
}

#[test]
fn garbage_gives_none() {
    for model in models() {
        for p in [
            [f64::NAN, 0.0, 1.0],
            [0.0, f64::INFINITY, 1.0],
            [0.0, 0.0, f64::NAN],
            [0.0, 0.0, f64::INFINITY],
        ] {
            assert_eq!(model.project(p), None);
            assert_eq!(model.project_jacobian(p), None);
        }
        for pixel in [[f64::NAN, 10.0], [10.0, f64::NEG_INFINITY], [1e300, 1e300]] {
            assert_eq!(model.unproject(pixel), None);
            assert_eq!(model.undistort_point(pixel), None);
        }
        let mut broken = model;
        broken.intrinsics.fx_px = -1.0;
        assert_eq!(broken.project([0.1, 0.1, 1.0]), None);
        assert_eq!(broken.unproject([10.0, 10.0]), None);
    }
}

#[test]
fn pinhole_point_far_outside_the_lens_is_rejected() {
    // With k1 = −0.3 alone the radial map r(1 − 0.3 r²) turns back at r = 1/√0.9 and
    // changes sign at r = 1/√0.3: a point at r = 3 (or r = 1.5) has no pixel.
    let mut model = webcam();
    model.distortion = Distortion::BrownConrady {
        k1: -0.3,
        k2: 0.0,
        p1: 0.0,
        p2: 0.0,
        k3: 0.0,
    };
    assert!(model.project([0.5, 0.0, 1.0]).is_some());
    assert_eq!(model.project([3.0, 0.0, 1.0]), None);
    assert_eq!(model.project([0.0, 1.5, 1.0]), None);
    // Nor does any pixel unproject to a folded point.
    assert!(model.unproject([-2230.5, 239.5]).is_none());
}

#[test]
fn models_round_trip_through_toml() {
    for model in models() {
        let text = toml::to_string(&model).unwrap();
        let back: CameraModel = toml::from_str(&text).unwrap();
        assert_eq!(back, model);
    }
    let text = "[intrinsics]\nfx_px = 300.0\nfy_px = 300.0\ncx_px = 320.0\ncy_px = 180.0\n\
                width_px = 640\nheight_px = 360\n\n[distortion]\nmodel = \"kannala_brandt\"\n\
                k1 = -0.02\nk2 = 0.005\nk3 = -0.001\nk4 = 0.0\n";
    assert_eq!(toml::from_str::<CameraModel>(text).unwrap(), fisheye());
}

proptest! {
    #[test]
    fn any_pixel_on_the_image_round_trips(
        fisheye_model in any::<bool>(),
        fu in 0.0..=1.0_f64,
        fv in 0.0..=1.0_f64,
        depth_m in 0.01..100.0_f64,
    ) {
        let model = if fisheye_model { fisheye() } else { webcam() };
        let i = model.intrinsics;
        let pixel = [
            -0.5 + fu * f64::from(i.width_px),
            -0.5 + fv * f64::from(i.height_px),
        ];
        let ray = model.unproject(pixel).unwrap();
        let back = model.project(ray.map(|c| c * depth_m)).unwrap();
        prop_assert!((back[0] - pixel[0]).hypot(back[1] - pixel[1]) < 1e-9);
        let again = model.unproject(back).unwrap();
        prop_assert!(angle_between_rad(ray, again) < 1e-9);
    }

    #[test]
    fn arbitrary_inputs_never_panic(
        p in prop::array::uniform3(any::<f64>()),
        pixel in prop::array::uniform2(any::<f64>()),
    ) {
        for model in models() {
            if let Some(q) = model.project(p) {
                prop_assert!(q.iter().all(|v| v.is_finite()));
            }
            if let Some(j) = model.project_jacobian(p) {
                prop_assert!(j.iter().flatten().all(|v| v.is_finite()));
            }
            if let Some(r) = model.unproject(pixel) {
                prop_assert!(r.iter().all(|v| v.is_finite()) && r[2] > 0.0);
            }
            if let Some(x) = model.undistort_point(pixel) {
                prop_assert!(x.iter().all(|v| v.is_finite()));
            }
        }
    }
}

/// A camera whose images are scaled sees every ray at the scaled pixel, the image's
/// corners staying at the corners.
#[test]
fn a_scaled_camera_sees_rays_at_the_scaled_pixels() {
    let cam = webcam();
    let half = cam.scaled_to(320, 240);
    assert_eq!(
        (half.intrinsics.width_px, half.intrinsics.height_px),
        (320, 240)
    );
    half.check().unwrap();
    for pixel in [[0.0, 0.0], [100.0, 50.0], [319.5, 239.5], [600.0, 420.0]] {
        let ray = cam.unproject(pixel).unwrap();
        let seen = half.project(ray).unwrap();
        assert_relative_eq!(seen[0], (pixel[0] + 0.5) * 0.5 - 0.5, epsilon = 1e-6);
        assert_relative_eq!(seen[1], (pixel[1] + 0.5) * 0.5 - 0.5, epsilon = 1e-6);
    }
    let pin = CameraModel::pinhole(400.0, 400.0, 159.5, 119.5, 320, 240);
    pin.check().unwrap();
    assert_relative_eq!(pin.project([0.0, 0.0, 1.0]).unwrap()[0], 159.5);
    assert_eq!(pin.distortion, Distortion::NONE);
}
