//! TCPROS, ROS 1's topic transport: the connection header both sides send first (a
//! length-prefixed list of `key=value` fields), then each message as its length and its
//! ROS 1 serialised bytes. The header and frame codecs are pure; [`read_frame`] reads one
//! frame from any async stream, refusing a length over a bound.

use std::collections::BTreeMap;
use tokio::io::{AsyncRead, AsyncReadExt};

/// The longest connection header taken, bytes.
pub const MAX_HEADER_BYTES: usize = 64 * 1024;

/// The longest message taken, bytes (a MiRo frame's JPEG is tens of kB).
pub const MAX_MESSAGE_BYTES: usize = 16 * 1024 * 1024;

/// What is wrong with a TCPROS stream.
#[derive(Debug, thiserror::Error)]
pub enum TcprosError {
    #[error("{what} of {len} bytes is over the {max}-byte limit")]
    TooLong {
        what: &'static str,
        len: usize,
        max: usize,
    },
    #[error("connection header: {0}")]
    Header(String),
    #[error("the publisher refused: {0}")]
    Refused(String),
    #[error(transparent)]
    Io(#[from] std::io::Error),
}

/// A connection header's fields as bytes on the wire (with the leading total length).
pub fn encode_header(fields: &[(&str, &str)]) -> Vec<u8> {
    let mut body = Vec::new();
    for (k, v) in fields {
        let field = format!("{k}={v}");
        body.extend_from_slice(&(field.len() as u32).to_le_bytes());
        body.extend_from_slice(field.as_bytes());
    }
    let mut out = (body.len() as u32).to_le_bytes().to_vec();
    out.extend(body);
    out
}

/// A connection header's fields from its bytes (without the leading total length).
pub fn decode_header(mut bytes: &[u8]) -> Result<BTreeMap<String, String>, TcprosError> {
    let mut fields = BTreeMap::new();
    while !bytes.is_empty() {
        let (len, rest) = bytes
            .split_first_chunk::<4>()
            .ok_or_else(|| TcprosError::Header("a field's length is cut short".into()))?;
        let len = u32::from_le_bytes(*len) as usize;
        if len > rest.len() {
            return Err(TcprosError::Header(format!(
                "a field of {len} bytes with {} left",
                rest.len()
            )));
        }
        let (field, rest) = rest.split_at(len);
        let field = std::str::from_utf8(field)
            .map_err(|_| TcprosError::Header("a field is not UTF-8".into()))?;
        let (k, v) = field
            .split_once('=')
            .ok_or_else(|| TcprosError::Header(format!("field {field:?} has no '='")))?;
        fields.insert(k.to_string(), v.to_string());
        bytes = rest;
    }
    Ok(fields)
}

/// One length-prefixed frame (a header or a message) of at most `max` bytes.
pub async fn read_frame<R: AsyncRead + Unpin>(
    stream: &mut R,
    what: &'static str,
    max: usize,
) -> Result<Vec<u8>, TcprosError> {
    let len = stream.read_u32_le().await? as usize;
    if len > max {
        return Err(TcprosError::TooLong { what, len, max });
    }
    let mut buf = vec![0u8; len];
    stream.read_exact(&mut buf).await?;
    Ok(buf)
}

/// The publisher's reply header: its fields, or its `error` as [`TcprosError::Refused`].
pub fn check_reply(fields: &BTreeMap<String, String>) -> Result<(), TcprosError> {
    match fields.get("error") {
        Some(e) => Err(TcprosError::Refused(e.clone())),
        None => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    #[test]
    fn headers_read_back_and_bad_ones_are_errors() {
        let bytes = encode_header(&[("topic", "/a"), ("md5sum", "*"), ("x", "a=b")]);
        assert_eq!(
            u32::from_le_bytes(bytes[..4].try_into().unwrap()) as usize,
            bytes.len() - 4
        );
        let f = decode_header(&bytes[4..]).unwrap();
        assert_eq!(f["topic"], "/a");
        assert_eq!(f["x"], "a=b");
        assert!(decode_header(&bytes[4..bytes.len() - 1]).is_err());
        assert!(decode_header(&[1, 0]).is_err());
        assert!(decode_header(&[3, 0, 0, 0, b'a', b'b', b'c']).is_err());
        let mut refused = BTreeMap::new();
        refused.insert("error".to_string(), "topic types do not match".to_string());
        assert!(matches!(
            check_reply(&refused),
            Err(TcprosError::Refused(_))
        ));
    }

    #[tokio::test]
    async fn frames_over_the_bound_are_refused() {
        let mut data: &[u8] = &[3, 0, 0, 0, 1, 2, 3, 200, 0, 0, 0];
        assert_eq!(
            read_frame(&mut data, "message", 10).await.unwrap(),
            [1, 2, 3]
        );
        assert!(matches!(
            read_frame(&mut data, "message", 10).await,
            Err(TcprosError::TooLong { len: 200, .. })
        ));
        let mut short: &[u8] = &[5, 0, 0, 0, 1];
        assert!(matches!(
            read_frame(&mut short, "message", 10).await,
            Err(TcprosError::Io(_))
        ));
    }
}
