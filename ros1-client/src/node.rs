//! A ROS 1 node that only subscribes: it registers its topics with the master, asks each
//! publisher for a TCPROS connection and hands every message's bytes to the caller. It
//! answers the master's calls (`publisherUpdate` when publishers come and go, `getPid`,
//! `getBusInfo`, ...) on a small XML-RPC server of its own, checks the master every
//! [`CHECK_PERIOD`], and when the master goes away and comes back registers again: one log
//! line when it is lost, one when it is back. A publisher of another type than the topic's
//! is refused once, with a log line naming both types, and not asked again until the
//! topic's publishers change.

use super::tcpros::{self, MAX_HEADER_BYTES, MAX_MESSAGE_BYTES, TcprosError};
use super::xmlrpc::{self, Value, XmlRpcError};
use std::collections::HashMap;
use std::net::{IpAddr, SocketAddr};
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Duration;
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::{TcpListener, TcpStream};
use tokio::sync::mpsc;
use tokio::task::JoinHandle;

/// How often the master is checked, and a lost publisher asked again.
pub const CHECK_PERIOD: Duration = Duration::from_secs(1);

/// How long one XML-RPC exchange may take.
const CALL_TIMEOUT: Duration = Duration::from_secs(2);

/// The longest XML-RPC request or response taken, bytes.
const MAX_XMLRPC_BYTES: usize = 1024 * 1024;

/// What went wrong talking to the ROS graph.
#[derive(Debug, thiserror::Error)]
pub enum Ros1Error {
    #[error("{0:?} is not an http://HOST:PORT/ URI")]
    BadUri(String),
    #[error("{uri}: {source}")]
    Io { uri: String, source: std::io::Error },
    #[error("{uri}: no answer within {CALL_TIMEOUT:?}")]
    Timeout { uri: String },
    #[error("{uri}: HTTP {detail}")]
    Http { uri: String, detail: String },
    #[error("{uri}: {source}")]
    XmlRpc { uri: String, source: XmlRpcError },
    #[error("{uri}: {method} failed: {message}")]
    Api {
        uri: String,
        method: String,
        message: String,
    },
    #[error("{uri}: {method} answered {answer:?}, not what ROS's API returns")]
    Shape {
        uri: String,
        method: String,
        answer: String,
    },
}

/// A topic to subscribe to.
#[derive(Debug, Clone)]
pub struct TopicSpec {
    /// The topic's name (`/miro/sensors/caml/compressed`).
    pub name: String,
    /// The message types taken (`sensor_msgs/CompressedImage`); a publisher of another is
    /// refused.
    pub types: Vec<String>,
}

/// What the node has seen, for the caller's summary.
#[derive(Debug, Default)]
pub struct NodeCounts {
    pub messages: AtomicU64,
    pub connections: AtomicU64,
    pub refused: AtomicU64,
}

/// Where a topic's messages go: the topic's index among those given, and the bytes.
pub type Deliver = Arc<dyn Fn(usize, &[u8]) + Send + Sync>;

/// The node's settings.
#[derive(Debug, Clone)]
pub struct NodeConfig {
    /// The master's URI (`http://localhost:11311`).
    pub master_uri: String,
    /// This node's name (`/robot_agent_miro1`).
    pub caller_id: String,
    /// The host or address others reach this node at; by default `ROS_IP`, `ROS_HOSTNAME`,
    /// 127.0.0.1 when the master is on this machine, or the address that routes to it.
    pub host: Option<String>,
}

/// A running subscriber node; dropping it unregisters nothing (the master drops a node it
/// cannot reach) but stops every connection.
pub struct Node {
    tasks: Vec<JoinHandle<()>>,
    pub counts: Arc<NodeCounts>,
    pub caller_api: String,
}

impl std::fmt::Debug for Node {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Node")
            .field("caller_api", &self.caller_api)
            .finish_non_exhaustive()
    }
}

impl Drop for Node {
    fn drop(&mut self) {
        for t in &self.tasks {
            t.abort();
        }
    }
}

/// `http://HOST:PORT/PATH` as (host, port, path).
pub fn parse_uri(uri: &str) -> Result<(String, u16, String), Ros1Error> {
    let bad = || Ros1Error::BadUri(uri.to_string());
    let rest = uri.strip_prefix("http://").ok_or_else(bad)?;
    let (authority, path) = match rest.find('/') {
        Some(i) => (&rest[..i], &rest[i..]),
        None => (rest, "/"),
    };
    let (host, port) = authority.rsplit_once(':').ok_or_else(bad)?;
    let port: u16 = port.parse().map_err(|_| bad())?;
    if host.is_empty() || port == 0 {
        return Err(bad());
    }
    Ok((host.to_string(), port, path.to_string()))
}

/// Reads an HTTP message's head and its `Content-Length` body.
async fn read_http(stream: &mut TcpStream) -> std::io::Result<(String, Vec<u8>)> {
    let mut buf = Vec::new();
    let mut chunk = [0u8; 4096];
    let head_end = loop {
        if let Some(i) = buf.windows(4).position(|w| w == b"\r\n\r\n") {
            break i;
        }
        if buf.len() > MAX_XMLRPC_BYTES {
            return Err(std::io::Error::other("HTTP head too long"));
        }
        let n = stream.read(&mut chunk).await?;
        if n == 0 {
            return Err(std::io::ErrorKind::UnexpectedEof.into());
        }
        buf.extend_from_slice(&chunk[..n]);
    };
    let head = String::from_utf8_lossy(&buf[..head_end]).into_owned();
    let mut body = buf[head_end + 4..].to_vec();
    let length = head
        .lines()
        .filter_map(|l| l.split_once(':'))
        .find(|(k, _)| k.trim().eq_ignore_ascii_case("content-length"))
        .and_then(|(_, v)| v.trim().parse::<usize>().ok());
    match length {
        Some(n) if n > MAX_XMLRPC_BYTES => {
            return Err(std::io::Error::other("HTTP body too long"));
        }
        Some(n) => {
            while body.len() < n {
                let got = stream.read(&mut chunk).await?;
                if got == 0 {
                    return Err(std::io::ErrorKind::UnexpectedEof.into());
                }
                body.extend_from_slice(&chunk[..got]);
            }
            body.truncate(n);
        }
        None => {
            stream.read_to_end(&mut body).await?;
        }
    }
    Ok((head, body))
}

/// One XML-RPC call to `uri`.
pub async fn call(uri: &str, method: &str, params: &[Value]) -> Result<Value, Ros1Error> {
    let (host, port, path) = parse_uri(uri)?;
    let io = |source| Ros1Error::Io {
        uri: uri.to_string(),
        source,
    };
    let exchange = async {
        let mut stream = TcpStream::connect((host.as_str(), port))
            .await
            .map_err(io)?;
        let body = xmlrpc::method_call(method, params);
        let request = format!(
            "POST {path} HTTP/1.1\r\nHost: {host}:{port}\r\nUser-Agent: robot-agent\r\n\
             Content-Type: text/xml\r\nContent-Length: {}\r\nConnection: close\r\n\r\n{body}",
            body.len()
        );
        stream.write_all(request.as_bytes()).await.map_err(io)?;
        read_http(&mut stream).await.map_err(io)
    };
    let (head, body) = tokio::time::timeout(CALL_TIMEOUT, exchange)
        .await
        .map_err(|_| Ros1Error::Timeout {
            uri: uri.to_string(),
        })??;
    let status = head.lines().next().unwrap_or("");
    if status.split_whitespace().nth(1) != Some("200") {
        return Err(Ros1Error::Http {
            uri: uri.to_string(),
            detail: status.to_string(),
        });
    }
    xmlrpc::parse_response(&String::from_utf8_lossy(&body)).map_err(|source| Ros1Error::XmlRpc {
        uri: uri.to_string(),
        source,
    })
}

/// A ROS API call: `[code, message, value]` with code 1 gives the value.
pub async fn api(uri: &str, method: &str, params: &[Value]) -> Result<Value, Ros1Error> {
    let answer = call(uri, method, params).await?;
    let shape = || Ros1Error::Shape {
        uri: uri.to_string(),
        method: method.to_string(),
        answer: format!("{answer:?}"),
    };
    let items = answer.as_array().ok_or_else(shape)?;
    let [code, message, value] = items else {
        return Err(shape());
    };
    match code.as_int() {
        Some(1) => Ok(value.clone()),
        Some(_) => Err(Ros1Error::Api {
            uri: uri.to_string(),
            method: method.to_string(),
            message: message.as_str().unwrap_or("").to_string(),
        }),
        None => Err(shape()),
    }
}

/// The URIs of a `registerSubscriber` or `publisherUpdate` list.
fn uris(value: &Value) -> Vec<String> {
    value
        .as_array()
        .unwrap_or(&[])
        .iter()
        .filter_map(|v| v.as_str().map(str::to_string))
        .collect()
}

/// The host others reach this node at (see [`NodeConfig::host`]).
fn advertised_host(config: &NodeConfig, master_host: &str) -> String {
    if let Some(h) = &config.host {
        return h.clone();
    }
    for var in ["ROS_IP", "ROS_HOSTNAME"] {
        if let Ok(v) = std::env::var(var)
            && !v.trim().is_empty()
        {
            return v.trim().to_string();
        }
    }
    let loopback = master_host == "localhost"
        || master_host
            .parse::<IpAddr>()
            .map(|ip| ip.is_loopback())
            .unwrap_or(false);
    if loopback {
        return "127.0.0.1".into();
    }
    // The address of the interface that routes to the master (no packet is sent).
    std::net::UdpSocket::bind("0.0.0.0:0")
        .and_then(|s| {
            s.connect((master_host, 9))?;
            s.local_addr()
        })
        .map(|a| a.ip().to_string())
        .unwrap_or_else(|_| "127.0.0.1".into())
}

/// The node's own XML-RPC server: answers the master and other nodes, passing publisher
/// updates on.
async fn serve(
    listener: TcpListener,
    caller_id: String,
    master_uri: String,
    topics: Vec<TopicSpec>,
    updates: mpsc::UnboundedSender<(String, Vec<String>)>,
) {
    loop {
        let Ok((mut stream, _)) = listener.accept().await else {
            tokio::time::sleep(Duration::from_millis(50)).await;
            continue;
        };
        let (caller_id, master_uri, topics, updates) = (
            caller_id.clone(),
            master_uri.clone(),
            topics.clone(),
            updates.clone(),
        );
        tokio::spawn(async move {
            let Ok(Ok((_, body))) =
                tokio::time::timeout(CALL_TIMEOUT, read_http(&mut stream)).await
            else {
                return;
            };
            let answer = match xmlrpc::parse_call(&String::from_utf8_lossy(&body)) {
                Ok((method, params)) => {
                    answer_call(&method, &params, &caller_id, &master_uri, &topics, &updates)
                }
                Err(e) => vec![Value::Int(-1), Value::Str(e.to_string()), Value::Int(0)],
            };
            let body = xmlrpc::method_response(&Value::Array(answer));
            let response = format!(
                "HTTP/1.0 200 OK\r\nContent-Type: text/xml\r\nContent-Length: {}\r\n\r\n{body}",
                body.len()
            );
            let _ = stream.write_all(response.as_bytes()).await;
            let _ = stream.shutdown().await;
        });
    }
}

/// The slave API's answer to one call.
fn answer_call(
    method: &str,
    params: &[Value],
    caller_id: &str,
    master_uri: &str,
    topics: &[TopicSpec],
    updates: &mpsc::UnboundedSender<(String, Vec<String>)>,
) -> Vec<Value> {
    let ok = |v: Value| vec![Value::Int(1), Value::Str(String::new()), v];
    match method {
        "publisherUpdate" => match params {
            [_, topic, publishers] if topic.as_str().is_some() => {
                let topic = topic.as_str().unwrap_or_default().to_string();
                let _ = updates.send((topic, uris(publishers)));
                ok(Value::Int(0))
            }
            _ => vec![
                Value::Int(-1),
                Value::from("publisherUpdate takes (caller_id, topic, publishers)"),
                Value::Int(0),
            ],
        },
        "getPid" => ok(Value::Int(std::process::id() as i32)),
        "getMasterUri" => ok(Value::Str(master_uri.to_string())),
        "getSubscriptions" => ok(Value::Array(
            topics
                .iter()
                .map(|t| {
                    Value::Array(vec![
                        Value::Str(t.name.clone()),
                        Value::Str(t.types.first().cloned().unwrap_or_else(|| "*".into())),
                    ])
                })
                .collect(),
        )),
        "getPublications" | "getBusInfo" => ok(Value::Array(Vec::new())),
        "getBusStats" => ok(Value::Array(vec![
            Value::Array(Vec::new()),
            Value::Array(Vec::new()),
            Value::Array(Vec::new()),
        ])),
        "paramUpdate" => ok(Value::Int(0)),
        "shutdown" => {
            let why = params.get(1).and_then(Value::as_str).unwrap_or("");
            let by = params.first().and_then(Value::as_str).unwrap_or("?");
            tracing::warn!(
                "{caller_id}: {by} asked this node to shut down ({why}); another node of the \
                 same name has probably started: give each robot's agent its own robot id"
            );
            ok(Value::Int(0))
        }
        other => vec![
            Value::Int(-1),
            Value::Str(format!("{other} is not a method of this node")),
            Value::Int(0),
        ],
    }
}

/// One publisher's connection: asks it for the topic over TCPROS, checks its type, and
/// delivers messages until it ends (`Ok`). An error says whether the publisher refused
/// (`true`: its type or its answer; not asked again) or could not be reached.
async fn connect_publisher(
    publisher: String,
    caller_id: String,
    topic: TopicSpec,
    index: usize,
    deliver: Deliver,
    counts: Arc<NodeCounts>,
) -> Result<(), (bool, String)> {
    let fail = |e: String| (false, e);
    let protocols = Value::Array(vec![Value::Array(vec![Value::from("TCPROS")])]);
    let params = [
        Value::Str(caller_id.clone()),
        Value::Str(topic.name.clone()),
        protocols,
    ];
    let answer = api(&publisher, "requestTopic", &params)
        .await
        .map_err(|e| fail(e.to_string()))?;
    let (host, port) = match answer.as_array() {
        Some([proto, host, port]) if proto.as_str() == Some("TCPROS") => (
            host.as_str().unwrap_or_default().to_string(),
            port.as_int().unwrap_or(0),
        ),
        _ => return Err(fail(format!("{publisher} offered {answer:?}, not TCPROS"))),
    };
    let port = u16::try_from(port).map_err(|_| fail(format!("{publisher}: port {port}")))?;
    let mut stream = tokio::time::timeout(CALL_TIMEOUT, TcpStream::connect((host.as_str(), port)))
        .await
        .map_err(|_| {
            fail(format!(
                "{host}:{port}: no connection within {CALL_TIMEOUT:?}"
            ))
        })?
        .map_err(|e| fail(format!("{host}:{port}: {e}")))?;
    let _ = stream.set_nodelay(true);
    let ty = if topic.types.len() == 1 {
        topic.types[0].as_str()
    } else {
        "*"
    };
    let header = tcpros::encode_header(&[
        ("callerid", &caller_id),
        ("topic", &topic.name),
        ("type", ty),
        ("md5sum", "*"),
        ("tcp_nodelay", "1"),
    ]);
    stream
        .write_all(&header)
        .await
        .map_err(|e| fail(format!("{host}:{port}: {e}")))?;
    let reply = tokio::time::timeout(
        CALL_TIMEOUT,
        tcpros::read_frame(&mut stream, "connection header", MAX_HEADER_BYTES),
    )
    .await
    .map_err(|_| fail(format!("{host}:{port}: no header within {CALL_TIMEOUT:?}")))?
    .map_err(|e| fail(e.to_string()))?;
    let fields = tcpros::decode_header(&reply).map_err(|e| fail(e.to_string()))?;
    if let Err(e) = tcpros::check_reply(&fields) {
        return Err((true, format!("{}: {e}", topic.name)));
    }
    let their_type = fields.get("type").map(String::as_str).unwrap_or("");
    if !topic.types.is_empty() && !topic.types.iter().any(|t| t == their_type) {
        return Err((
            true,
            format!(
                "{} carries {their_type:?} from {publisher}, not {}: not read",
                topic.name,
                topic.types.join(" or ")
            ),
        ));
    }
    counts.connections.fetch_add(1, Ordering::Relaxed);
    tracing::info!("{}: reading from {publisher} ({their_type})", topic.name);
    loop {
        match tcpros::read_frame(&mut stream, "message", MAX_MESSAGE_BYTES).await {
            Ok(bytes) => {
                counts.messages.fetch_add(1, Ordering::Relaxed);
                deliver(index, &bytes);
            }
            Err(TcprosError::Io(e)) if e.kind() == std::io::ErrorKind::UnexpectedEof => {
                tracing::info!("{}: {publisher} closed the connection", topic.name);
                return Ok(());
            }
            Err(e) => {
                tracing::warn!("{}: {publisher}: {e}; connection dropped", topic.name);
                return Ok(());
            }
        }
    }
}

/// A topic's publishers and their connections.
#[derive(Default)]
struct TopicState {
    publishers: Vec<String>,
    connections: HashMap<String, JoinHandle<()>>,
    /// Publishers refused (wrong type, or they refused us) until the list changes.
    refused: std::collections::HashSet<String>,
}

/// The supervisor: registers the topics, keeps a connection to every publisher, follows the
/// master's updates and re-registers when the master comes back.
async fn supervise(
    config: NodeConfig,
    caller_api: String,
    topics: Vec<TopicSpec>,
    deliver: Deliver,
    counts: Arc<NodeCounts>,
    mut updates: mpsc::UnboundedReceiver<(String, Vec<String>)>,
) {
    let mut states: Vec<TopicState> = topics.iter().map(|_| TopicState::default()).collect();
    let (refused_tx, mut refused_rx) = mpsc::unbounded_channel::<(usize, String)>();
    // The master's pid while it answers; None while it does not (or before the first call).
    let mut master: Option<i32> = None;
    let mut lost_logged = false;
    let mut tick = tokio::time::interval(CHECK_PERIOD);
    tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    loop {
        tokio::select! {
            _ = tick.tick() => {}
            Some((topic, list)) = updates.recv() => {
                if let Some(i) = topics.iter().position(|t| t.name == topic) {
                    set_publishers(&mut states[i], list);
                }
            }
            Some((i, publisher)) = refused_rx.recv() => {
                states[i].refused.insert(publisher);
                continue;
            }
        }
        let pid = api(
            &config.master_uri,
            "getPid",
            &[Value::Str(config.caller_id.clone())],
        )
        .await
        .ok()
        .and_then(|v| v.as_int());
        match (master, pid) {
            (_, None) => {
                if !lost_logged {
                    tracing::warn!(
                        "ROS master {} does not answer; asking again every {:?}",
                        config.master_uri,
                        CHECK_PERIOD
                    );
                    lost_logged = true;
                }
                master = None;
            }
            (old, Some(p)) if old != Some(p) => {
                // A master first reached, back, or restarted: register everything again.
                let mut registered = true;
                for (i, t) in topics.iter().enumerate() {
                    let ty = if t.types.len() == 1 {
                        t.types[0].clone()
                    } else {
                        "*".into()
                    };
                    let params = [
                        Value::Str(config.caller_id.clone()),
                        Value::Str(t.name.clone()),
                        Value::Str(ty),
                        Value::Str(caller_api.clone()),
                    ];
                    match api(&config.master_uri, "registerSubscriber", &params).await {
                        Ok(list) => set_publishers(&mut states[i], uris(&list)),
                        Err(e) => {
                            tracing::warn!("registering {}: {e}", t.name);
                            registered = false;
                            break;
                        }
                    }
                }
                if registered {
                    let how = if old.is_none() && lost_logged {
                        "is back"
                    } else {
                        "answers"
                    };
                    tracing::info!(
                        "ROS master {} {how}: subscribed to {} topics as {}",
                        config.master_uri,
                        topics.len(),
                        config.caller_id
                    );
                    master = Some(p);
                    lost_logged = false;
                }
            }
            _ => {}
        }
        // Connections to every listed publisher not refused; ended ones are made again.
        for (i, state) in states.iter_mut().enumerate() {
            state.connections.retain(|_, h| !h.is_finished());
            for publisher in state.publishers.clone() {
                if state.connections.contains_key(&publisher) || state.refused.contains(&publisher)
                {
                    continue;
                }
                let (caller_id, topic, deliver, counts, refused_tx) = (
                    config.caller_id.clone(),
                    topics[i].clone(),
                    deliver.clone(),
                    counts.clone(),
                    refused_tx.clone(),
                );
                let p = publisher.clone();
                let handle = tokio::spawn(async move {
                    // Asked again every period while it fails: the first failure after a
                    // success is logged, the rest only at debug level.
                    let mut quiet = false;
                    loop {
                        let attempt = connect_publisher(
                            p.clone(),
                            caller_id.clone(),
                            topic.clone(),
                            i,
                            deliver.clone(),
                            counts.clone(),
                        )
                        .await;
                        match attempt {
                            Err((true, why)) => {
                                counts.refused.fetch_add(1, Ordering::Relaxed);
                                tracing::error!("{why}");
                                let _ = refused_tx.send((i, p));
                                return;
                            }
                            Err((false, why)) if quiet => tracing::debug!("{}: {why}", topic.name),
                            Err((false, why)) => {
                                tracing::warn!(
                                    "{}: {why}; asking again every {CHECK_PERIOD:?}",
                                    topic.name
                                );
                                quiet = true;
                            }
                            Ok(()) => quiet = false,
                        }
                        tokio::time::sleep(CHECK_PERIOD).await;
                    }
                });
                state.connections.insert(publisher, handle);
            }
        }
    }
}

/// A topic's new publisher list: connections to those gone stop, refusals are forgotten.
fn set_publishers(state: &mut TopicState, list: Vec<String>) {
    if state.publishers == list {
        return;
    }
    state.connections.retain(|uri, h| {
        let keep = list.contains(uri);
        if !keep {
            h.abort();
        }
        keep
    });
    state.refused.clear();
    state.publishers = list;
}

impl Node {
    /// Starts the node: its XML-RPC server, then the supervisor, which reaches the master
    /// (now or whenever it answers) and the publishers. Fails only on a bad master URI or
    /// when no port can be bound.
    pub async fn start(
        config: NodeConfig,
        topics: Vec<TopicSpec>,
        deliver: Deliver,
    ) -> Result<Node, Ros1Error> {
        let (master_host, _, _) = parse_uri(&config.master_uri)?;
        let host = advertised_host(&config, &master_host);
        let bind_ip: IpAddr = match host.parse::<IpAddr>() {
            Ok(ip) if ip.is_loopback() => ip,
            _ if host == "localhost" => IpAddr::from([127, 0, 0, 1]),
            _ => IpAddr::from([0, 0, 0, 0]),
        };
        let listener = TcpListener::bind(SocketAddr::new(bind_ip, 0))
            .await
            .map_err(|source| Ros1Error::Io {
                uri: format!("{bind_ip}:0"),
                source,
            })?;
        let port = listener
            .local_addr()
            .map_err(|source| Ros1Error::Io {
                uri: format!("{bind_ip}:0"),
                source,
            })?
            .port();
        let caller_api = format!("http://{host}:{port}/");
        let counts = Arc::new(NodeCounts::default());
        let (updates_tx, updates_rx) = mpsc::unbounded_channel();
        let server = tokio::spawn(serve(
            listener,
            config.caller_id.clone(),
            config.master_uri.clone(),
            topics.clone(),
            updates_tx,
        ));
        let supervisor = tokio::spawn(supervise(
            config,
            caller_api.clone(),
            topics,
            deliver,
            counts.clone(),
            updates_rx,
        ));
        Ok(Node {
            tasks: vec![server, supervisor],
            counts,
            caller_api,
        })
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    #[test]
    fn uris_parse_or_are_refused() {
        assert_eq!(
            parse_uri("http://localhost:11311").unwrap(),
            ("localhost".into(), 11311, "/".into())
        );
        assert_eq!(
            parse_uri("http://10.0.0.2:4567/RPC2").unwrap(),
            ("10.0.0.2".into(), 4567, "/RPC2".into())
        );
        for bad in [
            "localhost:11311",
            "http://:11311/",
            "http://host/",
            "http://h:0/",
            "http://h:x/",
        ] {
            assert!(parse_uri(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn the_node_answers_the_masters_calls() {
        let (tx, mut rx) = mpsc::unbounded_channel();
        let topics = vec![TopicSpec {
            name: "/a".into(),
            types: vec!["sensor_msgs/JointState".into()],
        }];
        let update = [
            Value::from("/master"),
            Value::from("/a"),
            Value::Array(vec![Value::from("http://h:1/")]),
        ];
        let a = answer_call(
            "publisherUpdate",
            &update,
            "/me",
            "http://m:1/",
            &topics,
            &tx,
        );
        assert_eq!(a[0], Value::Int(1));
        assert_eq!(
            rx.try_recv().unwrap(),
            ("/a".to_string(), vec!["http://h:1/".to_string()])
        );
        let subs = answer_call("getSubscriptions", &[], "/me", "http://m:1/", &topics, &tx);
        assert_eq!(
            subs[2],
            Value::Array(vec![Value::Array(vec![
                Value::from("/a"),
                Value::from("sensor_msgs/JointState")
            ])])
        );
        assert_eq!(
            answer_call("publisherUpdate", &[], "/me", "", &topics, &tx)[0],
            Value::Int(-1)
        );
        assert_eq!(
            answer_call("launchMissiles", &[], "/me", "", &topics, &tx)[0],
            Value::Int(-1)
        );
    }

    #[test]
    fn a_new_publisher_list_drops_refusals_and_gone_publishers() {
        let mut s = TopicState {
            publishers: vec!["http://a:1/".into()],
            ..TopicState::default()
        };
        s.refused.insert("http://a:1/".into());
        set_publishers(&mut s, vec!["http://a:1/".into()]);
        assert!(
            s.refused.contains("http://a:1/"),
            "the same list keeps refusals"
        );
        set_publishers(&mut s, vec!["http://b:1/".into()]);
        assert!(s.refused.is_empty());
        assert_eq!(s.publishers, vec!["http://b:1/".to_string()]);
    }

    /// A stand-in master and publisher speaking XML-RPC and TCPROS on loopback (the real
    /// master is tested in tests/miro/ros1.sh).
    async fn fake_graph(ty: &'static str) -> (String, tokio::task::JoinHandle<()>) {
        let tcpros = TcpListener::bind("127.0.0.1:0").await.unwrap();
        let tcpros_port = tcpros.local_addr().unwrap().port();
        let api = TcpListener::bind("127.0.0.1:0").await.unwrap();
        let uri = format!("http://127.0.0.1:{}/", api.local_addr().unwrap().port());
        let me = uri.clone();
        let task = tokio::spawn(async move {
            let xmlrpc_server = async {
                loop {
                    let (mut s, _) = api.accept().await.unwrap();
                    let (_, body) = read_http(&mut s).await.unwrap();
                    let (method, _) = xmlrpc::parse_call(&String::from_utf8_lossy(&body)).unwrap();
                    let value = match method.as_str() {
                        "getPid" => Value::Int(42),
                        // The master and the publisher are one: it lists itself.
                        "registerSubscriber" => Value::Array(vec![Value::Str(me.clone())]),
                        "requestTopic" => Value::Array(vec![
                            Value::from("TCPROS"),
                            Value::from("127.0.0.1"),
                            Value::Int(i32::from(tcpros_port)),
                        ]),
                        _ => Value::Int(0),
                    };
                    let body = xmlrpc::method_response(&Value::Array(vec![
                        Value::Int(1),
                        Value::from(""),
                        value,
                    ]));
                    let r = format!(
                        "HTTP/1.0 200 OK\r\nContent-Length: {}\r\n\r\n{body}",
                        body.len()
                    );
                    s.write_all(r.as_bytes()).await.unwrap();
                }
            };
            let topic_server = async {
                loop {
                    let (mut s, _) = tcpros.accept().await.unwrap();
                    let header = tcpros::read_frame(&mut s, "header", MAX_HEADER_BYTES)
                        .await
                        .unwrap();
                    let fields = tcpros::decode_header(&header).unwrap();
                    assert_eq!(fields["md5sum"], "*");
                    s.write_all(&tcpros::encode_header(&[("type", ty), ("md5sum", "x")]))
                        .await
                        .unwrap();
                    for k in 0..3u8 {
                        s.write_all(&[1, 0, 0, 0, k]).await.unwrap();
                    }
                }
            };
            tokio::join!(xmlrpc_server, topic_server);
        });
        (uri, task)
    }

    #[tokio::test(flavor = "multi_thread")]
    async fn messages_arrive_from_a_publisher_of_the_right_type_only() {
        for (ty, expect) in [("sensor_msgs/JointState", true), ("std_msgs/String", false)] {
            let (master, graph) = fake_graph(ty).await;
            let got = Arc::new(std::sync::Mutex::new(Vec::new()));
            let deliver: Deliver = {
                let got = got.clone();
                Arc::new(move |i, bytes: &[u8]| got.lock().unwrap().push((i, bytes.to_vec())))
            };
            let node = Node::start(
                NodeConfig {
                    master_uri: master,
                    caller_id: "/test".into(),
                    host: Some("127.0.0.1".into()),
                },
                vec![TopicSpec {
                    name: "/joints".into(),
                    types: vec!["sensor_msgs/JointState".into()],
                }],
                deliver,
            )
            .await
            .unwrap();
            let deadline = std::time::Instant::now() + Duration::from_secs(5);
            while std::time::Instant::now() < deadline
                && got.lock().unwrap().len() < 3
                && node.counts.refused.load(Ordering::Relaxed) == 0
            {
                tokio::time::sleep(Duration::from_millis(20)).await;
            }
            let got = got.lock().unwrap().clone();
            if expect {
                assert_eq!(got[..3], [(0, vec![0]), (0, vec![1]), (0, vec![2])]);
            } else {
                assert!(got.is_empty());
                assert_eq!(node.counts.refused.load(Ordering::Relaxed), 1);
            }
            graph.abort();
        }
    }
}
