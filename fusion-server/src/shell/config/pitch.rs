//! The pitch, from wherever it comes: the defaults, the file's `[pitch]` table, then the
//! pitch flags, each replacing what it names. Checked once it is whole, so that the ball
//! fitting on the pitch is checked whichever source set which size.

use super::{ConfigError, positive};
use clap::Args;
use proto::{Pitch, Stamp, Validate, ValidationContext, WallSide};
use std::str::FromStr;

/// Flags over the pitch of the configuration file (or the MiRo pitch without one).
#[derive(Debug, Clone, Default, PartialEq, Args)]
#[command(next_help_heading = "Pitch (over the file's [pitch]; default the MiRo pitch)")]
pub struct PitchFlags {
    /// Inner length between the x walls, metres [default: 3.9]
    #[arg(long, value_name = "M", value_parser = positive_number, allow_negative_numbers = true)]
    pub pitch_length_m: Option<f64>,
    /// Inner width between the y walls, metres [default: 2.6]
    #[arg(long, value_name = "M", value_parser = positive_number, allow_negative_numbers = true)]
    pub pitch_width_m: Option<f64>,
    /// Ball radius, metres [default: 0.04]
    #[arg(long, value_name = "M", value_parser = positive_number, allow_negative_numbers = true)]
    pub ball_radius_m: Option<f64>,
    /// Wall restitution, normal speed out over normal speed in, strictly between 0 and 1:
    /// where the filter's restitution starts before it learns one [default: 0.5]
    #[arg(long, value_name = "E", value_parser = restitution, allow_negative_numbers = true)]
    pub wall_restitution: Option<f64>,
    /// Sides that have a wall, comma-separated from x_max, x_min, y_max, y_min; `all`, or
    /// `none` for an open pitch [default: all]
    #[arg(long, value_name = "SIDES")]
    pub walls: Option<WallSides>,
}

/// The sides given to `--walls`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct WallSides(pub Vec<WallSide>);

impl FromStr for WallSides {
    type Err = String;

    /// `none`, `all`, or side names as in the file and on the wire (`x_max,y_min`).
    fn from_str(s: &str) -> Result<Self, String> {
        match s.trim() {
            "none" => return Ok(WallSides(Vec::new())),
            "all" => return Ok(WallSides(WallSide::ALL.to_vec())),
            _ => {}
        }
        let mut sides = Vec::new();
        for name in s.split(',').map(str::trim) {
            let side: WallSide = serde_json::from_value(serde_json::Value::from(name))
                .map_err(|e| format!("{e} (or `all`, or `none` for no walls)"))?;
            if !sides.contains(&side) {
                sides.push(side);
            }
        }
        Ok(WallSides(sides))
    }
}

fn number(s: &str) -> Result<f64, String> {
    s.trim()
        .parse::<f64>()
        .map_err(|e| format!("{s:?} is not a number: {e}"))
}

fn positive_number(s: &str) -> Result<f64, String> {
    let v = number(s)?;
    if v.is_finite() && v > 0.0 {
        Ok(v)
    } else {
        Err(format!("must be positive, got {v}"))
    }
}

fn restitution(s: &str) -> Result<f64, String> {
    number(s).and_then(restitution_value)
}

fn restitution_value(v: f64) -> Result<f64, String> {
    if v > 0.0 && v < 1.0 {
        Ok(v)
    } else {
        Err(format!("must be between 0 and 1 (both excluded), got {v}"))
    }
}

impl PitchFlags {
    /// `base` (the file's pitch, or the default) with these flags over it, checked.
    pub fn over(&self, base: &Pitch) -> Result<Pitch, ConfigError> {
        let mut p = base.clone();
        if let Some(v) = self.pitch_length_m {
            p.length_m = v;
        }
        if let Some(v) = self.pitch_width_m {
            p.width_m = v;
        }
        if let Some(v) = self.ball_radius_m {
            p.ball_radius_m = v;
        }
        if let Some(v) = self.wall_restitution {
            p.wall_restitution = v;
        }
        if let Some(w) = &self.walls {
            p.walls = w.0.clone();
        }
        check_pitch(&p)?;
        Ok(p)
    }
}

/// A pitch the server can work on: the version it speaks, positive sizes, a restitution
/// strictly between 0 and 1 (the filter learns it from there), a ball that fits, and
/// what receivers of the pitch accept.
pub fn check_pitch(p: &Pitch) -> Result<(), ConfigError> {
    if p.version != proto::VERSION {
        return Err(ConfigError::Invalid(format!(
            "pitch.version {} is not supported (this build speaks {})",
            p.version,
            proto::VERSION
        )));
    }
    positive("pitch.length_m", p.length_m)?;
    positive("pitch.width_m", p.width_m)?;
    positive("pitch.ball_radius_m", p.ball_radius_m)?;
    restitution_value(p.wall_restitution)
        .map_err(|e| ConfigError::Invalid(format!("pitch.wall_restitution {e}")))?;
    if 2.0 * p.ball_radius_m >= p.length_m.min(p.width_m) {
        return Err(ConfigError::Invalid(format!(
            "the ball (radius {} m) does not fit on a {} m × {} m pitch",
            p.ball_radius_m, p.length_m, p.width_m
        )));
    }
    p.validate(&ValidationContext::new(p.clone(), Stamp(0)))
        .map_err(|e| ConfigError::Invalid(format!("pitch: {e}")))
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    #[derive(Debug, Parser)]
    struct Cmd {
        #[command(flatten)]
        pitch: PitchFlags,
    }

    fn flags(args: &[&str]) -> Result<PitchFlags, clap::Error> {
        Cmd::try_parse_from(std::iter::once("cmd").chain(args.iter().copied())).map(|c| c.pitch)
    }

    #[test]
    fn flags_replace_only_what_they_name() -> Result<(), Box<dyn std::error::Error>> {
        let base = Pitch {
            length_m: 5.0,
            wall_restitution: 0.7,
            ..Pitch::default()
        };
        let f = flags(&["--pitch-width-m", "3", "--walls", "x_min, y_max,x_min"])?;
        let p = f.over(&base)?;
        assert_eq!(
            p,
            Pitch {
                width_m: 3.0,
                walls: vec![WallSide::XMin, WallSide::YMax],
                ..base.clone()
            }
        );
        let all = flags(&[
            "--pitch-length-m",
            "4",
            "--ball-radius-m",
            "0.05",
            "--wall-restitution",
            "0.3",
            "--walls",
            "none",
        ])?
        .over(&base)?;
        assert_eq!(
            (all.length_m, all.ball_radius_m, all.wall_restitution),
            (4.0, 0.05, 0.3)
        );
        assert!(all.walls.is_empty());
        assert_eq!(flags(&[])?.over(&base)?, base);
        Ok(())
    }

    #[test]
    fn bad_flags_say_what_is_wrong() {
        for (args, needle) in [
            (&["--pitch-length-m", "0"][..], "must be positive, got 0"),
            (&["--pitch-width-m", "wide"], "is not a number"),
            (&["--ball-radius-m", "-0.1"], "must be positive, got -0.1"),
            (&["--wall-restitution", "1"], "between 0 and 1"),
            (&["--wall-restitution", "NaN"], "between 0 and 1"),
            (
                &["--walls", "x_mx"],
                "unknown variant `x_mx`, expected one of",
            ),
            (&["--walls", "x_max,"], "unknown variant ``"),
        ] {
            match flags(args) {
                Err(e) => {
                    let text = e.to_string();
                    assert!(text.contains(needle), "{args:?}: {text}");
                }
                Ok(f) => panic!("{args:?} parsed: {f:?}"),
            }
        }
        let huge_ball = flags(&["--ball-radius-m", "1.5"]).expect("parses");
        match huge_ball.over(&Pitch::default()) {
            Err(ConfigError::Invalid(m)) => assert!(m.contains("does not fit"), "{m}"),
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn a_file_pitch_is_checked() {
        for (bad, needle) in [
            (
                Pitch {
                    version: 2,
                    ..Pitch::default()
                },
                "pitch.version 2",
            ),
            (
                Pitch {
                    width_m: -1.0,
                    ..Pitch::default()
                },
                "pitch.width_m must be positive",
            ),
            (
                Pitch {
                    wall_restitution: 0.0,
                    ..Pitch::default()
                },
                "pitch.wall_restitution must be between 0 and 1",
            ),
            (
                Pitch {
                    length_m: 5000.0,
                    ..Pitch::default()
                },
                "pitch: field length_m is out of range",
            ),
        ] {
            match check_pitch(&bad) {
                Err(ConfigError::Invalid(m)) => assert!(m.contains(needle), "{m}"),
                other => panic!("{bad:?}: {other:?}"),
            }
        }
        assert!(check_pitch(&Pitch::default()).is_ok());
    }
}
