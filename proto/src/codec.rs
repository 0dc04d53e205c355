//! The one encode/decode pair: JSON, with the version checked on the way in.

use serde::{Serialize, de::DeserializeOwned};
use thiserror::Error;

#[derive(Debug, Error)]
pub enum DecodeError {
    #[error("payload is not valid JSON for this message: {0}")]
    Json(#[from] serde_json::Error),
    #[error("unsupported wire version {found} (this build speaks {expected})")]
    Version { found: u64, expected: u32 },
    #[error("payload has no numeric \"version\" field")]
    MissingVersion,
}

/// Encodes a message as JSON bytes.
pub fn encode<T: Serialize>(msg: &T) -> Vec<u8> {
    // Serialising these plain structs cannot fail (no maps with non-string keys).
    serde_json::to_vec(msg).unwrap_or_default()
}

/// Decodes JSON bytes, rejecting any version other than [`crate::VERSION`] before looking
/// at the rest, so a newer sender gets a clear error rather than a confusing field error.
pub fn decode<T: DeserializeOwned>(bytes: &[u8]) -> Result<T, DecodeError> {
    #[derive(serde::Deserialize)]
    struct Versioned {
        version: Option<serde_json::Value>,
    }
    let head: Versioned = serde_json::from_slice(bytes)?;
    match head.version.as_ref().and_then(serde_json::Value::as_u64) {
        None => Err(DecodeError::MissingVersion),
        Some(v) if v != u64::from(crate::VERSION) => Err(DecodeError::Version {
            found: v,
            expected: crate::VERSION,
        }),
        Some(_) => Ok(serde_json::from_slice(bytes)?),
    }
}
