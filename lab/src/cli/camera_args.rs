//! The camera model of a folder of photos, from the command line: none (each photo searched
//! as it is), a plain pinhole (`--camera pinhole:FX,FY,CX,CY`) or a calibration file of
//! `ball-lab calibrate` (`--calibration FILE`), checked against, or with
//! `--rescale-calibration` scaled to, each photo's size.

use anyhow::{Context, Result, bail};
use std::collections::BTreeSet;
use std::path::PathBuf;
use std::str::FromStr;
use vision::camera::CameraModel;
use vision::photo::fit_to_photo;

/// Flags choosing the camera model of photos.
#[derive(Debug, Clone, clap::Args)]
pub struct CameraArgs {
    /// A plain pinhole camera, `pinhole:FX,FY,CX,CY` (focal lengths and principal point,
    /// pixels, at the photos' size). Default: no camera model, each photo is searched as it
    /// is.
    #[arg(long, conflicts_with = "calibration")]
    pub camera: Option<CameraSpec>,
    /// A calibration from `ball-lab calibrate` (TOML) for the photos' camera.
    #[arg(long)]
    pub calibration: Option<PathBuf>,
    /// Scale the calibration to photos of another size (the same shape resized), with a
    /// warning, instead of refusing them.
    #[arg(long, requires = "calibration")]
    pub rescale_calibration: bool,
}

/// How `--camera` names a camera model.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum CameraSpec {
    Pinhole {
        fx_px: f64,
        fy_px: f64,
        cx_px: f64,
        cy_px: f64,
    },
}

impl FromStr for CameraSpec {
    type Err = anyhow::Error;

    fn from_str(s: &str) -> Result<Self> {
        let usage = || format!("camera {s:?} is not pinhole:FX,FY,CX,CY (pixels)");
        let Some(("pinhole", numbers)) = s.split_once(':') else {
            bail!(usage());
        };
        let values: Vec<f64> = numbers
            .split(',')
            .map(|n| n.trim().parse::<f64>())
            .collect::<Result<_, _>>()
            .with_context(usage)?;
        let &[fx_px, fy_px, cx_px, cy_px] = values.as_slice() else {
            bail!("{}: four numbers, not {}", usage(), values.len());
        };
        if !values.iter().all(|v| v.is_finite()) || fx_px <= 0.0 || fy_px <= 0.0 {
            bail!("{}: focal lengths must be positive and all finite", usage());
        }
        Ok(CameraSpec::Pinhole {
            fx_px,
            fy_px,
            cx_px,
            cy_px,
        })
    }
}

/// The camera model chosen by [`CameraArgs`], made for each photo's size.
#[derive(Debug)]
pub struct PhotoCamera {
    choice: Choice,
    rescale: bool,
    /// Photo sizes the calibration was scaled to and warned about.
    warned: BTreeSet<(u32, u32)>,
}

#[derive(Debug)]
enum Choice {
    None,
    Pinhole(CameraSpec),
    Calibration { model: CameraModel, name: String },
}

impl PhotoCamera {
    /// Reads the calibration file, if one was given.
    pub fn new(args: &CameraArgs) -> Result<Self> {
        let choice = match (&args.calibration, args.camera) {
            (Some(path), _) => Choice::Calibration {
                model: robot_agent::load_models(Some(path), None)?[0],
                name: path.display().to_string(),
            },
            (None, Some(spec)) => Choice::Pinhole(spec),
            (None, None) => Choice::None,
        };
        Ok(PhotoCamera {
            choice,
            rescale: args.rescale_calibration,
            warned: BTreeSet::new(),
        })
    }

    /// The model for a photo of `width_px × height_px`; a calibration of another size is
    /// an error unless rescaling was asked for, which warns once per size.
    pub fn for_photo(&mut self, width_px: u32, height_px: u32) -> Result<Option<CameraModel>> {
        match &self.choice {
            Choice::None => Ok(None),
            Choice::Pinhole(CameraSpec::Pinhole {
                fx_px,
                fy_px,
                cx_px,
                cy_px,
            }) => {
                let model =
                    CameraModel::pinhole(*fx_px, *fy_px, *cx_px, *cy_px, width_px, height_px);
                model.check().context("--camera")?;
                Ok(Some(model))
            }
            Choice::Calibration { model, name } => {
                let fitted = fit_to_photo(model, width_px, height_px, self.rescale)
                    .with_context(|| format!("{name} does not fit the photos"))?;
                if fitted != *model && self.warned.insert((width_px, height_px)) {
                    let i = &model.intrinsics;
                    eprintln!(
                        "warning: {name} is for {}×{} px images; scaled to {width_px}×{height_px} px",
                        i.width_px, i.height_px
                    );
                }
                Ok(Some(fitted))
            }
        }
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]

    use super::*;

    #[test]
    fn the_pinhole_flag_parses() {
        assert_eq!(
            "pinhole:500,505.5,319.5,239.5"
                .parse::<CameraSpec>()
                .unwrap(),
            CameraSpec::Pinhole {
                fx_px: 500.0,
                fy_px: 505.5,
                cx_px: 319.5,
                cy_px: 239.5
            }
        );
        assert!("pinhole: 500, 500, 320, 240".parse::<CameraSpec>().is_ok());
    }

    #[test]
    fn a_malformed_pinhole_flag_says_what_is_expected() {
        for bad in [
            "pinhole:500,500,320",
            "pinhole:500,500,320,240,1",
            "pinhole:500,x,320,240",
            "pinhole:",
            "pinhole:0,500,320,240",
            "pinhole:-1,500,320,240",
            "pinhole:inf,500,320,240",
            "fisheye:500,500,320,240",
            "500,500,320,240",
        ] {
            let err = bad.parse::<CameraSpec>().unwrap_err();
            assert!(
                format!("{err:#}").contains("pinhole:FX,FY,CX,CY"),
                "{bad}: {err:#}"
            );
        }
    }

    #[test]
    fn a_calibration_of_another_size_is_refused_unless_rescaled() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("cam.toml");
        std::fs::write(&path, robot_agent::builtin::SIM_CALIBRATION_TOML).unwrap();
        let args = |rescale| CameraArgs {
            camera: None,
            calibration: Some(path.clone()),
            rescale_calibration: rescale,
        };
        let mut strict = PhotoCamera::new(&args(false)).unwrap();
        assert!(strict.for_photo(640, 360).unwrap().is_some());
        let err = format!("{:#}", strict.for_photo(320, 180).unwrap_err());
        assert!(err.contains("640×360") && err.contains("320×180"), "{err}");
        let mut lenient = PhotoCamera::new(&args(true)).unwrap();
        let half = lenient.for_photo(320, 180).unwrap().unwrap();
        assert_eq!(half.intrinsics.width_px, 320);
        let none = PhotoCamera::new(&CameraArgs {
            camera: None,
            calibration: None,
            rescale_calibration: false,
        });
        assert!(none.unwrap().for_photo(100, 100).unwrap().is_none());
    }
}
