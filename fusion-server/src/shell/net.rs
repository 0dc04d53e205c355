//! Zenoh session settings: the product-wide ones from `proto::net`.

pub use proto::net::NetConfig;
