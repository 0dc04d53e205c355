//! The replayed states as CSV, one row per state asked for (see [`ReplaySink::state`]),
//! for analysts (spreadsheets, pandas): the estimate, its uncertainty, what the filter
//! learned and where it expects the ball to stop.

use super::ReplaySink;
use proto::{BallState, BallStatus, Stamp};
use std::io::Write;

/// The header; the covariance entries are those of the state's 4 × 4 matrix over
/// (x, y, vx, vy).
pub const HEADER: &str = "t_ns,t_s,status,state_stamp_ns,x_m,y_m,vx_mps,vy_mps,\
var_x_m2,var_y_m2,cov_xy_m2,var_vx_m2ps2,var_vy_m2ps2,last_seen_ns,\
decel_mps2,restitution,stop_x_m,stop_y_m,stop_after_s";

/// Writes a row for each state handed to it; the first write error is kept for
/// [`StatesCsv::finish`].
#[derive(Debug)]
pub struct StatesCsv<W: Write> {
    out: W,
    /// `t_s` counts from here (the log's first message).
    origin: Stamp,
    error: Option<std::io::Error>,
    rows: u64,
}

fn status_name(s: BallStatus) -> &'static str {
    match s {
        BallStatus::Tracking => "tracking",
        BallStatus::Coasting => "coasting",
        BallStatus::Stopped => "stopped",
        BallStatus::Lost => "lost",
    }
}

/// One row: `none` and empty fields when there was no estimate at `at`.
fn row(at: Stamp, origin: Stamp, state: Option<&BallState>) -> String {
    let head = format!("{},{}", at.0, at.secs_since(origin));
    let Some(s) = state else {
        return format!("{head},none{}", ",".repeat(16));
    };
    let c = &s.covariance;
    let stop = s.prediction.stop.as_ref();
    let opt = |v: Option<f64>| v.map(|v| v.to_string()).unwrap_or_default();
    format!(
        "{head},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}",
        status_name(s.status),
        s.stamp.0,
        s.position_m[0],
        s.position_m[1],
        s.velocity_mps[0],
        s.velocity_mps[1],
        c[0],
        c[5],
        c[1],
        c[10],
        c[15],
        s.last_seen.map(|l| l.0.to_string()).unwrap_or_default(),
        s.model.rolling_decel_mps2,
        s.model.wall_restitution,
        opt(stop.map(|p| p.position_m[0])),
        opt(stop.map(|p| p.position_m[1])),
        opt(stop.map(|p| p.t_s)),
    )
}

impl<W: Write> StatesCsv<W> {
    /// Starts the file with its header.
    pub fn new(mut out: W, origin: Stamp) -> Self {
        let error = writeln!(out, "{HEADER}").err();
        StatesCsv {
            out,
            origin,
            error,
            rows: 0,
        }
    }

    /// Rows written.
    #[cfg(test)]
    pub fn rows(&self) -> u64 {
        self.rows
    }

    /// Flushes; the first error of any write.
    pub fn finish(mut self) -> std::io::Result<W> {
        if let Some(e) = self.error.take() {
            return Err(e);
        }
        self.out.flush()?;
        Ok(self.out)
    }
}

impl<W: Write> ReplaySink for StatesCsv<W> {
    fn write(&mut self, _: &str, _: &str, _: Stamp, _: &[u8]) {}

    fn writes(&self) -> bool {
        false
    }

    fn state(&mut self, at: Stamp, state: Option<&BallState>) {
        if self.error.is_some() {
            return;
        }
        match writeln!(self.out, "{}", row(at, self.origin, state)) {
            Ok(()) => self.rows += 1,
            Err(e) => self.error = Some(e),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proto::{ModelParams, Prediction, StopPoint};

    const T0: Stamp = Stamp(1_795_478_399_000_000_000);

    fn state() -> BallState {
        let mut covariance = [0.0; 16];
        for (i, v) in covariance.iter_mut().enumerate() {
            *v = i as f64;
        }
        BallState {
            version: proto::VERSION,
            stamp: T0.offset_secs(1.5),
            position_m: [0.5, -0.25],
            velocity_mps: [1.0, 0.0],
            covariance,
            status: BallStatus::Coasting,
            last_seen: Some(T0.offset_secs(0.9)),
            contributors: vec!["miro1".into()],
            existence: 1.0,
            model: ModelParams {
                rolling_decel_mps2: 0.3,
                wall_restitution: 0.6,
                decel_samples: 3,
                restitution_samples: 1,
                tangential_retention: 0.85,
                slide_decel_mps2: 3.0,
                bounces_seen: 0,
                kicks_inferred: 0,
            },
            prediction: Prediction {
                version: proto::VERSION,
                stamp: T0.offset_secs(1.5),
                horizon_s: 3.0,
                samples: Vec::new(),
                bounces: Vec::new(),
                stop: Some(StopPoint {
                    t_s: 2.0,
                    position_m: [1.1, -0.25],
                    covariance_m2: None,
                }),
            },
        }
    }

    #[test]
    fn rows_match_the_header_with_and_without_an_estimate() -> std::io::Result<()> {
        let mut csv = StatesCsv::new(Vec::new(), T0);
        csv.state(T0.offset_secs(0.5), None);
        csv.state(T0.offset_secs(1.5), Some(&state()));
        assert_eq!(csv.rows(), 2);
        let text = String::from_utf8(csv.finish()?).expect("utf-8");
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines[0], HEADER);
        let columns = HEADER.split(',').count();
        for l in &lines[1..] {
            assert_eq!(l.split(',').count(), columns, "{l}");
        }
        assert_eq!(
            lines[1],
            format!("{},0.5,none,,,,,,,,,,,,,,,,", T0.0 + 500_000_000)
        );
        let at = T0.0 + 1_500_000_000;
        let seen = T0.0 + 900_000_000;
        assert_eq!(
            lines[2],
            format!("{at},1.5,coasting,{at},0.5,-0.25,1,0,0,5,1,10,15,{seen},0.3,0.6,1.1,-0.25,2")
        );
        Ok(())
    }
}
