//! The pitch: its size, which sides have walls, and how they bounce the ball.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

/// One side of the rectangular pitch.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum WallSide {
    /// The wall at x = +length/2.
    XMax,
    /// The wall at x = −length/2.
    XMin,
    /// The wall at y = +width/2.
    YMax,
    /// The wall at y = −width/2.
    YMin,
}

impl WallSide {
    pub const ALL: [WallSide; 4] = [
        WallSide::XMax,
        WallSide::XMin,
        WallSide::YMax,
        WallSide::YMin,
    ];
}

/// Pitch geometry, centred on the origin, x along the long side. Omitted fields take the
/// MiRo pitch's values; on the wire the version is still required.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
// Defaults let a configuration file say only what differs from the MiRo pitch.
#[serde(default, deny_unknown_fields)]
#[schemars(transform = version_required)]
pub struct Pitch {
    pub version: u32,
    /// Inner length between the x walls.
    pub length_m: f64,
    /// Inner width between the y walls.
    pub width_m: f64,
    /// Sides that have a wall; the ball leaves the pitch through the others.
    pub walls: Vec<WallSide>,
    /// Default coefficient of restitution of the walls (normal speed out / in).
    pub wall_restitution: f64,
    pub ball_radius_m: f64,
}

/// `decode` rejects a message without a version, defaults or not: the schema says so.
fn version_required(schema: &mut schemars::Schema) {
    schema.insert("required".into(), serde_json::json!(["version"]));
}

impl Default for Pitch {
    /// The MiRo pitch: 3.9 m × 2.6 m with walls all round, ball radius 0.04 m.
    fn default() -> Self {
        Pitch {
            version: crate::VERSION,
            length_m: 3.9,
            width_m: 2.6,
            walls: WallSide::ALL.to_vec(),
            wall_restitution: 0.5,
            ball_radius_m: 0.04,
        }
    }
}

impl Pitch {
    pub fn half_length_m(&self) -> f64 {
        0.5 * self.length_m
    }

    pub fn half_width_m(&self) -> f64 {
        0.5 * self.width_m
    }

    pub fn has_wall(&self, side: WallSide) -> bool {
        self.walls.contains(&side)
    }

    /// Signed distance from `[x, y]` to the pitch rectangle: negative inside.
    pub fn outside_distance_m(&self, p: [f64; 2]) -> f64 {
        let dx = p[0].abs() - self.half_length_m();
        let dy = p[1].abs() - self.half_width_m();
        if dx <= 0.0 && dy <= 0.0 {
            dx.max(dy)
        } else {
            dx.max(0.0).hypot(dy.max(0.0))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{DecodeError, decode};

    #[test]
    fn omitted_fields_take_the_miro_pitch() {
        let p: Pitch = decode(br#"{"version": 1, "length_m": 5.0, "walls": []}"#).expect("decodes");
        assert_eq!(
            p,
            Pitch {
                length_m: 5.0,
                walls: Vec::new(),
                ..Pitch::default()
            }
        );
    }

    #[test]
    fn the_wire_still_needs_the_version() {
        let r = decode::<Pitch>(br#"{"length_m": 5.0}"#);
        assert!(matches!(r, Err(DecodeError::MissingVersion)), "{r:?}");
    }
}
