//! A robot program's view of the shared ball (with the `zenoh` feature): the ball states the
//! fusion server publishes, and its answers to "where will the ball be" and "where can I
//! meet it", typed and checked.
//!
//! ```no_run
//! # async fn run() -> Result<(), proto::client::ClientError> {
//! use proto::client::BallClient;
//! use proto::net::NetConfig;
//! use std::time::Duration;
//!
//! let client = BallClient::connect(&NetConfig::connecting("tcp/127.0.0.1:7447"), "rf").await?;
//! client.wait_for_server(Duration::from_secs(5)).await?;
//! let mut states = client.subscribe().await?;
//! if let Some(state) = states.next().await {
//!     println!("ball at {:?}", state.position_m);
//! }
//! let meet = client.intercept("miro1", Some(0.4)).await?;
//! println!("miro1 meets it at {:?} in {:.1} s", meet.point_m, meet.t_s);
//! # Ok(()) }
//! ```
//!
//! On a secured network, give the robot's own key folder (`NetConfig::tls`,
//! [`crate::net::TlsFiles::in_dir`]) and `tls/` endpoints.

use crate::net::{NetConfig, NetError};
use crate::{BallState, DecodeError, Intercept, KeyError, KeySpace, Prediction};
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering::Relaxed};
use std::time::Duration;
use thiserror::Error;

/// How long a query waits for the server's answer unless told otherwise.
pub const DEFAULT_QUERY_TIMEOUT: Duration = Duration::from_secs(2);

#[derive(Debug, Error)]
pub enum ClientError {
    #[error(transparent)]
    Net(#[from] NetError),
    #[error(transparent)]
    Key(#[from] KeyError),
    #[error("zenoh: {0}")]
    Zenoh(String),
    #[error(
        "no fusion server answered within {waited_s:.1} s on {endpoints}: is it running, on the same prefix ({prefix}), and reachable from here?"
    )]
    NoServer {
        endpoints: String,
        prefix: String,
        waited_s: f64,
    },
    #[error("no answer to {selector} within {waited_s:.1} s")]
    NoReply { selector: String, waited_s: f64 },
    /// The server answered with an error (no ball yet, an unknown robot, ...).
    #[error("the server refused {selector}: {message}")]
    Refused { selector: String, message: String },
    #[error("the answer to {selector} is not valid: {source}")]
    BadReply {
        selector: String,
        #[source]
        source: DecodeError,
    },
    #[error("a query parameter must be finite and not negative, got {0}")]
    BadParameter(f64),
}

fn zenoh_error(e: impl std::fmt::Display) -> ClientError {
    ClientError::Zenoh(e.to_string())
}

/// A session on the robots' Zenoh network, reading the ball.
#[derive(Debug, Clone)]
pub struct BallClient {
    session: zenoh::Session,
    keys: KeySpace,
    endpoints: String,
    query_timeout: Duration,
}

impl BallClient {
    /// Joins the network `net` describes (usually: connect to the server's endpoint).
    pub async fn connect(net: &NetConfig, prefix: &str) -> Result<Self, ClientError> {
        let keys = KeySpace::new(prefix)?;
        let session = net.open().await?;
        Ok(BallClient {
            session,
            keys,
            endpoints: net.connect.join(", "),
            query_timeout: DEFAULT_QUERY_TIMEOUT,
        })
    }

    /// Sets how long queries wait for an answer.
    pub fn with_query_timeout(mut self, timeout: Duration) -> Self {
        self.query_timeout = timeout;
        self
    }

    /// Waits until a fusion server is on the network (its liveliness token answers), at
    /// most `timeout`; returns its id.
    pub async fn wait_for_server(&self, timeout: Duration) -> Result<String, ClientError> {
        let start = tokio::time::Instant::now();
        let pattern = format!("{}/servers/*", self.keys.prefix());
        loop {
            let left = timeout.saturating_sub(start.elapsed());
            let replies = self
                .session
                .liveliness()
                .get(&pattern)
                .timeout(
                    left.min(Duration::from_millis(500))
                        .max(Duration::from_millis(50)),
                )
                .await
                .map_err(zenoh_error)?;
            while let Ok(reply) = replies.recv_async().await {
                if let Ok(sample) = reply.result() {
                    let key = sample.key_expr().as_str();
                    let id = key.rsplit('/').next().unwrap_or(key);
                    return Ok(id.to_string());
                }
            }
            if start.elapsed() >= timeout {
                return Err(ClientError::NoServer {
                    endpoints: self.endpoints.clone(),
                    prefix: self.keys.prefix().to_string(),
                    waited_s: timeout.as_secs_f64(),
                });
            }
            tokio::time::sleep(Duration::from_millis(50)).await;
        }
    }

    /// The ball states as they are published, checked; malformed ones are skipped and
    /// counted ([`BallStates::rejected`]).
    pub async fn subscribe(&self) -> Result<BallStates, ClientError> {
        let subscriber = self
            .session
            .declare_subscriber(self.keys.ball_state())
            .await
            .map_err(zenoh_error)?;
        Ok(BallStates {
            subscriber,
            rejected: Arc::new(AtomicU64::new(0)),
        })
    }

    /// The path predicted `horizon_s` seconds ahead of the latest estimate.
    pub async fn predict(&self, horizon_s: f64) -> Result<Prediction, ClientError> {
        if !(horizon_s.is_finite() && horizon_s >= 0.0) {
            return Err(ClientError::BadParameter(horizon_s));
        }
        self.ask(&format!("t={horizon_s}")).await
    }

    /// Where robot `robot_id` (from its last reported pose) can meet the ball, moving at
    /// `speed_mps` (the server's configured speed when `None`).
    pub async fn intercept(
        &self,
        robot_id: &str,
        speed_mps: Option<f64>,
    ) -> Result<Intercept, ClientError> {
        if !crate::is_valid_id(robot_id) {
            return Err(KeyError::BadChunk(robot_id.to_string()).into());
        }
        let parameters = match speed_mps {
            Some(s) if !(s.is_finite() && s >= 0.0) => return Err(ClientError::BadParameter(s)),
            Some(s) => format!("robot={robot_id};speed={s}"),
            None => format!("robot={robot_id}"),
        };
        self.ask(&parameters).await
    }

    async fn ask<T: serde::de::DeserializeOwned>(
        &self,
        parameters: &str,
    ) -> Result<T, ClientError> {
        let selector = format!("{}?{parameters}", self.keys.ball_predict());
        let replies = self
            .session
            .get(&selector)
            .timeout(self.query_timeout)
            .await
            .map_err(zenoh_error)?;
        let Ok(reply) = replies.recv_async().await else {
            return Err(ClientError::NoReply {
                selector,
                waited_s: self.query_timeout.as_secs_f64(),
            });
        };
        match reply.result() {
            Ok(sample) => crate::decode(&sample.payload().to_bytes())
                .map_err(|source| ClientError::BadReply { selector, source }),
            Err(e) => Err(ClientError::Refused {
                selector,
                message: String::from_utf8_lossy(&e.payload().to_bytes()).into_owned(),
            }),
        }
    }

    /// Leaves the network.
    pub async fn close(self) -> Result<(), ClientError> {
        self.session.close().await.map_err(zenoh_error)
    }
}

/// The published ball states, in order.
#[derive(Debug)]
pub struct BallStates {
    subscriber:
        zenoh::pubsub::Subscriber<zenoh::handlers::FifoChannelHandler<zenoh::sample::Sample>>,
    rejected: Arc<AtomicU64>,
}

impl BallStates {
    /// The next valid state; `None` once the session is closed.
    pub async fn next(&mut self) -> Option<BallState> {
        loop {
            let sample = self.subscriber.recv_async().await.ok()?;
            match crate::decode::<BallState>(&sample.payload().to_bytes()) {
                Ok(state) => return Some(state),
                Err(e) => {
                    let n = self.rejected.fetch_add(1, Relaxed) + 1;
                    if n == 1 || n.is_power_of_two() {
                        warn_skipped(&e, n);
                    }
                }
            }
        }
    }

    /// States skipped because they were not valid.
    pub fn rejected(&self) -> u64 {
        self.rejected.load(Relaxed)
    }
}

/// Tells the program's standard error about skipped states, now and then (this crate
/// logs nothing else).
fn warn_skipped(e: &DecodeError, n: u64) {
    eprintln!("ball client: skipped an invalid ball state ({e}); {n} so far");
}
