//! Writing a node's folder: the layout `fusion-server keys` gives every node and
//! [`proto::net::TlsFiles::in_dir`] reads (`ca.pem`, `cert.pem`, `key.pem`).

use crate::security::keys::Issued;
use std::io::Write;
use std::path::Path;

/// Writes `node`'s certificate and key, and the authority's certificate `ca_pem`, into
/// `dir` (made if need be). The key is readable by its owner only.
pub fn write(dir: &Path, ca_pem: &str, node: &Issued) -> std::io::Result<()> {
    std::fs::create_dir_all(dir)?;
    let files = proto::net::TlsFiles::in_dir(dir);
    std::fs::write(&files.ca, ca_pem)?;
    std::fs::write(&files.cert, &node.cert_pem)?;
    write_secret(&files.key, &node.key_pem)
}

/// Writes a private key readable by its owner only.
pub fn write_secret(path: &Path, text: &str) -> std::io::Result<()> {
    let mut o = std::fs::OpenOptions::new();
    o.write(true).create(true).truncate(true);
    #[cfg(unix)]
    std::os::unix::fs::OpenOptionsExt::mode(&mut o, 0o600);
    o.open(path)?.write_all(text.as_bytes())
}
