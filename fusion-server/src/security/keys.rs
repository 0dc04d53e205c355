//! The network's certificate authority and the certificates it issues (pure: the date is
//! passed in, PEM text comes out; `fusion-server keys` writes the files).
//!
//! Keys are ECDSA P-256. Every leaf certificate may serve and connect (servers and routers
//! accept links and open them; robots only open them), and names its node in its common
//! name ([`crate::security`]). Servers' and routers' certificates also carry the host names
//! and addresses they are reached at, which connecting nodes check.

use rcgen::{
    BasicConstraints, CertificateParams, DnType, ExtendedKeyUsagePurpose, IsCa, Issuer, KeyPair,
    KeyUsagePurpose,
};
use thiserror::Error;

#[derive(Debug, Error)]
pub enum KeysError {
    #[error("certificate: {0}")]
    Rcgen(#[from] rcgen::Error),
    #[error("date: {0}")]
    Date(String),
}

/// A certificate and its private key, both PEM.
#[derive(Debug, Clone)]
pub struct Issued {
    pub cert_pem: String,
    pub key_pem: String,
}

/// The first and last day (UTC) a certificate is valid.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Validity {
    pub from: jiff::civil::Date,
    pub until: jiff::civil::Date,
}

impl Validity {
    /// From the day before `now` (clocks differ) for `days` days.
    pub fn starting(now: jiff::Timestamp, days: u32) -> Result<Self, KeysError> {
        let today = now.to_zoned(jiff::tz::TimeZone::UTC).date();
        let date = |d: Result<jiff::civil::Date, jiff::Error>| {
            d.map_err(|e| KeysError::Date(e.to_string()))
        };
        Ok(Validity {
            from: date(today.checked_sub(jiff::Span::new().days(1)))?,
            until: date(today.checked_add(jiff::Span::new().days(i64::from(days))))?,
        })
    }

    fn apply(&self, p: &mut CertificateParams) {
        let t = |d: jiff::civil::Date| {
            rcgen::date_time_ymd(i32::from(d.year()), d.month() as u8, d.day() as u8)
        };
        p.not_before = t(self.from);
        p.not_after = t(self.until);
    }
}

/// The certificate authority: signs every node's certificate; its certificate (not its
/// key) goes to every node.
#[derive(Debug)]
pub struct Authority {
    pub issued: Issued,
    issuer: Issuer<'static, KeyPair>,
}

impl Authority {
    /// A new authority named `name`.
    pub fn new(name: &str, validity: Validity) -> Result<Self, KeysError> {
        let key = KeyPair::generate()?;
        let mut p = CertificateParams::new(Vec::<String>::new())?;
        p.distinguished_name.push(DnType::CommonName, name);
        p.is_ca = IsCa::Ca(BasicConstraints::Unconstrained);
        p.key_usages = vec![
            KeyUsagePurpose::KeyCertSign,
            KeyUsagePurpose::CrlSign,
            KeyUsagePurpose::DigitalSignature,
        ];
        validity.apply(&mut p);
        let cert = p.self_signed(&key)?;
        let issued = Issued {
            cert_pem: cert.pem(),
            key_pem: key.serialize_pem(),
        };
        Ok(Authority {
            issued,
            issuer: Issuer::new(p, key),
        })
    }

    /// An authority made earlier, from its certificate and key (to add nodes later).
    pub fn load(cert_pem: &str, key_pem: &str) -> Result<Self, KeysError> {
        let key = KeyPair::from_pem(key_pem)?;
        let issuer = Issuer::from_ca_cert_pem(cert_pem, key)?;
        Ok(Authority {
            issued: Issued {
                cert_pem: cert_pem.to_string(),
                key_pem: key_pem.to_string(),
            },
            issuer,
        })
    }

    /// A node's certificate: `common_name` names it, `hosts` (DNS names or IP addresses)
    /// are where it can be reached.
    pub fn issue(
        &self,
        common_name: &str,
        hosts: &[String],
        validity: Validity,
    ) -> Result<Issued, KeysError> {
        let key = KeyPair::generate()?;
        let mut p = CertificateParams::new(hosts.to_vec())?;
        p.distinguished_name.push(DnType::CommonName, common_name);
        p.use_authority_key_identifier_extension = true;
        p.key_usages = vec![KeyUsagePurpose::DigitalSignature];
        p.extended_key_usages = vec![
            ExtendedKeyUsagePurpose::ServerAuth,
            ExtendedKeyUsagePurpose::ClientAuth,
        ];
        validity.apply(&mut p);
        let cert = p.signed_by(&key, &self.issuer)?;
        Ok(Issued {
            cert_pem: cert.pem(),
            key_pem: key.serialize_pem(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn validity() -> Result<Validity, KeysError> {
        let now = jiff::Timestamp::from_second(1_800_000_000)
            .map_err(|e| KeysError::Date(e.to_string()))?;
        Validity::starting(now, 365)
    }

    #[test]
    fn validity_starts_the_day_before() -> Result<(), KeysError> {
        let v = validity()?;
        // 1_800_000_000 s is 2027-01-15 08:00 UTC.
        assert_eq!(v.from.to_string(), "2027-01-14");
        assert_eq!(v.until.to_string(), "2028-01-15");
        Ok(())
    }

    #[test]
    fn issued_certificates_name_their_node_and_chain_to_the_authority() -> Result<(), KeysError> {
        let ca = Authority::new("rf test authority", validity()?)?;
        let leaf = ca.issue(
            "robot:miro1",
            &["localhost".into(), "127.0.0.1".into()],
            validity()?,
        )?;
        assert!(leaf.cert_pem.starts_with("-----BEGIN CERTIFICATE-----"));
        assert!(leaf.key_pem.contains("PRIVATE KEY"));
        // The authority reloads from its files and keeps issuing under the same name.
        let again = Authority::load(&ca.issued.cert_pem, &ca.issued.key_pem)?;
        let other = again.issue("server:main", &[], validity()?)?;
        let der = |pem: &str| -> Vec<u8> {
            use base64::Engine;
            let body: String = pem.lines().filter(|l| !l.starts_with("-----")).collect();
            base64::engine::general_purpose::STANDARD
                .decode(body)
                .unwrap_or_default()
        };
        let (ca_der, leaf_der, other_der) = (
            der(&ca.issued.cert_pem),
            der(&leaf.cert_pem),
            der(&other.cert_pem),
        );
        // The issuer's name (the authority's subject) is in both leaves; the common names
        // are where they should be.
        let name = b"rf test authority";
        for d in [&ca_der, &leaf_der, &other_der] {
            assert!(d.windows(name.len()).any(|w| w == name));
        }
        assert!(leaf_der.windows(11).any(|w| w == b"robot:miro1"));
        assert!(other_der.windows(11).any(|w| w == b"server:main"));
        assert!(!ca_der.windows(11).any(|w| w == b"robot:miro1"));
        Ok(())
    }
}
