//! Key expressions, all under one configurable prefix (default `rf`).

use thiserror::Error;

pub const DEFAULT_PREFIX: &str = "rf";

#[derive(Debug, Error, PartialEq)]
pub enum KeyError {
    #[error("key chunk {0:?} must be 1..=64 characters of A-Z a-z 0-9 _ -")]
    BadChunk(String),
    #[error("prefix {0:?} must be non-empty chunks of A-Z a-z 0-9 _ - separated by '/'")]
    BadPrefix(String),
}

/// True for a single key-expression chunk safe to use as a robot or server id.
pub fn is_valid_id(id: &str) -> bool {
    (1..=64).contains(&id.len())
        && id
            .bytes()
            .all(|b| b.is_ascii_alphanumeric() || b == b'_' || b == b'-')
}

/// Builds every key expression of the system under one prefix.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct KeySpace {
    prefix: String,
}

impl Default for KeySpace {
    fn default() -> Self {
        KeySpace {
            prefix: DEFAULT_PREFIX.to_string(),
        }
    }
}

impl KeySpace {
    pub fn new(prefix: &str) -> Result<Self, KeyError> {
        let ok = !prefix.is_empty() && prefix.split('/').all(is_valid_id);
        if ok {
            Ok(KeySpace {
                prefix: prefix.to_string(),
            })
        } else {
            Err(KeyError::BadPrefix(prefix.to_string()))
        }
    }

    pub fn prefix(&self) -> &str {
        &self.prefix
    }

    fn robot_key(&self, robot_id: &str, leaf: &str) -> Result<String, KeyError> {
        if !is_valid_id(robot_id) {
            return Err(KeyError::BadChunk(robot_id.to_string()));
        }
        Ok(format!("{}/robots/{robot_id}{leaf}", self.prefix))
    }

    /// `{prefix}/robots/{id}/obs`: a robot's `Observation`s.
    pub fn robot_obs(&self, robot_id: &str) -> Result<String, KeyError> {
        self.robot_key(robot_id, "/obs")
    }

    /// `{prefix}/robots/{id}/status`: a robot's `RobotStatus`.
    pub fn robot_status(&self, robot_id: &str) -> Result<String, KeyError> {
        self.robot_key(robot_id, "/status")
    }

    /// `{prefix}/robots/{id}/view/{camera}`: a robot's `CameraView`s of one camera.
    pub fn robot_view(&self, robot_id: &str, camera: crate::Camera) -> Result<String, KeyError> {
        self.robot_key(robot_id, &format!("/view/{}", camera_chunk(camera)))
    }

    /// `{prefix}/robots/*/view/*`: every robot's camera views.
    pub fn all_views(&self) -> String {
        format!("{}/robots/*/view/*", self.prefix)
    }

    /// `{prefix}/robots/{id}`: a robot's liveliness token.
    pub fn robot_liveliness(&self, robot_id: &str) -> Result<String, KeyError> {
        self.robot_key(robot_id, "")
    }

    /// `{prefix}/robots/*/obs`: every robot's observations.
    pub fn all_obs(&self) -> String {
        format!("{}/robots/*/obs", self.prefix)
    }

    /// `{prefix}/robots/*/status`: every robot's status.
    pub fn all_status(&self) -> String {
        format!("{}/robots/*/status", self.prefix)
    }

    /// `{prefix}/robots/*`: every robot's liveliness token.
    pub fn all_robot_liveliness(&self) -> String {
        format!("{}/robots/*", self.prefix)
    }

    /// `{prefix}/ball/state`: the fused `BallState`.
    pub fn ball_state(&self) -> String {
        format!("{}/ball/state", self.prefix)
    }

    /// `{prefix}/ball/predict`: the prediction / intercept queryable.
    pub fn ball_predict(&self) -> String {
        format!("{}/ball/predict", self.prefix)
    }

    /// `{prefix}/servers/{id}`: a fusion server's liveliness token.
    pub fn server_liveliness(&self, server_id: &str) -> Result<String, KeyError> {
        if !is_valid_id(server_id) {
            return Err(KeyError::BadChunk(server_id.to_string()));
        }
        Ok(format!("{}/servers/{server_id}", self.prefix))
    }

    /// The robot id in a key such as `{prefix}/robots/{id}/obs`, if it is one.
    pub fn robot_id_of<'k>(&self, key: &'k str) -> Option<&'k str> {
        self.robot_chunk_of(key).filter(|id| is_valid_id(id))
    }

    /// The chunk where a robot id belongs in `{prefix}/robots/{chunk}/…`, valid id or not
    /// (`None` when the key is not under `{prefix}/robots/`). A receiver must reject a
    /// message whose chunk is not a valid id rather than skip the comparison with the
    /// payload's `robot_id`.
    pub fn robot_chunk_of<'k>(&self, key: &'k str) -> Option<&'k str> {
        let rest = key.strip_prefix(&self.prefix)?.strip_prefix("/robots/")?;
        rest.split('/').next()
    }
}

/// The key chunk of a camera: `left` or `right`.
pub fn camera_chunk(camera: crate::Camera) -> &'static str {
    match camera {
        crate::Camera::Left => "left",
        crate::Camera::Right => "right",
    }
}

/// The camera a key chunk names.
pub fn camera_of_chunk(chunk: &str) -> Option<crate::Camera> {
    match chunk {
        "left" => Some(crate::Camera::Left),
        "right" => Some(crate::Camera::Right),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_keys_match_the_protocol() {
        let k = KeySpace::default();
        assert_eq!(k.robot_obs("miro1").as_deref(), Ok("rf/robots/miro1/obs"));
        assert_eq!(k.robot_status("m-2").as_deref(), Ok("rf/robots/m-2/status"));
        assert_eq!(k.robot_liveliness("m").as_deref(), Ok("rf/robots/m"));
        assert_eq!(k.all_obs(), "rf/robots/*/obs");
        assert_eq!(k.ball_state(), "rf/ball/state");
        assert_eq!(k.ball_predict(), "rf/ball/predict");
        assert_eq!(
            k.robot_view("miro1", crate::Camera::Right).as_deref(),
            Ok("rf/robots/miro1/view/right")
        );
        assert_eq!(k.all_views(), "rf/robots/*/view/*");
        assert_eq!(k.robot_id_of("rf/robots/miro1/view/left"), Some("miro1"));
        assert_eq!(
            camera_of_chunk(camera_chunk(crate::Camera::Left)),
            Some(crate::Camera::Left)
        );
        assert_eq!(k.server_liveliness("s1").as_deref(), Ok("rf/servers/s1"));
        assert_eq!(k.robot_id_of("rf/robots/miro1/obs"), Some("miro1"));
        assert_eq!(k.robot_id_of("xx/robots/miro1/obs"), None);
        assert_eq!(k.robot_id_of("rf/robots/not.an.id/obs"), None);
        assert_eq!(
            k.robot_chunk_of("rf/robots/not.an.id/obs"),
            Some("not.an.id")
        );
        assert_eq!(k.robot_chunk_of("rf/ball/state"), None);
    }

    #[test]
    fn custom_prefix_and_bad_chunks() {
        let k = KeySpace::new("lab/pitch_2").expect("valid prefix");
        assert_eq!(k.ball_state(), "lab/pitch_2/ball/state");
        assert!(KeySpace::new("").is_err());
        assert!(KeySpace::new("a//b").is_err());
        assert!(KeySpace::new("a/*").is_err());
        assert_eq!(
            k.robot_obs("a/b"),
            Err(KeyError::BadChunk("a/b".to_string()))
        );
        assert!(k.robot_obs("").is_err());
        assert!(k.robot_obs("**").is_err());
    }
}
