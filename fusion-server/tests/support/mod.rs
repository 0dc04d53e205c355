//! Running the real `fusion-server` binary in tests: child processes that die with the
//! test, the addresses they print, and a minimal HTTP client.

#![allow(dead_code)]

use std::io::{BufRead, BufReader};
use std::process::{Child, Command, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant};

pub const BIN: &str = env!("CARGO_BIN_EXE_fusion-server");

/// A child process killed (SIGKILL) when dropped.
#[derive(Debug)]
pub struct Proc {
    pub child: Child,
    pub lines: mpsc::Receiver<String>,
}

impl Proc {
    pub fn spawn(args: &[&str]) -> Proc {
        let mut child = Command::new(BIN)
            .args(args)
            // RF_TEST_SERVER_LOG overrides the server's log filter when debugging a test.
            .env(
                "RUST_LOG",
                std::env::var("RF_TEST_SERVER_LOG").unwrap_or("warn,zenoh=error".into()),
            )
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit())
            .spawn()
            .expect("spawn fusion-server");
        let out = child.stdout.take().expect("stdout");
        let (tx, lines) = mpsc::channel();
        std::thread::spawn(move || {
            for line in BufReader::new(out).lines().map_while(Result::ok) {
                if tx.send(line).is_err() {
                    break;
                }
            }
        });
        Proc { child, lines }
    }

    /// The first printed line that starts with `prefix`, within `timeout`.
    pub fn line_starting(&self, prefix: &str, timeout: Duration) -> String {
        let deadline = Instant::now() + timeout;
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            match self.lines.recv_timeout(left) {
                Ok(l) if l.starts_with(prefix) => return l,
                Ok(_) => continue,
                Err(e) => panic!("no line starting with {prefix:?}: {e}"),
            }
        }
    }

    /// Sends SIGTERM and waits for the exit status.
    pub fn terminate(&mut self, timeout: Duration) -> std::process::ExitStatus {
        let pid = self.child.id().to_string();
        let _ = Command::new("kill").args(["-TERM", &pid]).status();
        let deadline = Instant::now() + timeout;
        loop {
            if let Ok(Some(s)) = self.child.try_wait() {
                return s;
            }
            assert!(Instant::now() < deadline, "process {pid} ignored SIGTERM");
            std::thread::sleep(Duration::from_millis(20));
        }
    }
}

impl Drop for Proc {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// Starts an open server on a free Zenoh port and an OS-chosen HTTP port; returns it, its
/// Zenoh endpoint and its HTTP address.
pub fn start_server(extra: &[&str]) -> (Proc, String, String) {
    start_server_on("tcp", &["--open"], extra)
}

/// Starts a server listening over `protocol` (`tcp` or `tls`) on a free loopback port,
/// with `security` (`--open`, or `--tls DIR --roster …`) and `extra` flags, and an
/// OS-chosen HTTP port; returns it, its Zenoh endpoint and its HTTP address.
pub fn start_server_on(
    protocol: &str,
    security: &[&str],
    extra: &[&str],
) -> (Proc, String, String) {
    let port = proto::net::free_loopback_port().expect("free port");
    let endpoint = format!("{protocol}/127.0.0.1:{port}");
    let mut args = vec!["serve"];
    args.extend_from_slice(security);
    args.extend_from_slice(&["--listen", &endpoint, "--http", "127.0.0.1:0"]);
    args.extend_from_slice(extra);
    let p = Proc::spawn(&args);
    let url = p.line_starting("http://", Duration::from_secs(30));
    let addr = url
        .trim_start_matches("http://")
        .trim_end_matches('/')
        .to_string();
    (p, endpoint, addr)
}

/// GET `path` from `addr`: (status code, body), whatever the status.
pub fn http_get(addr: &str, path: &str) -> Result<(u16, String), ureq::Error> {
    let agent: ureq::Agent = ureq::Agent::config_builder()
        .http_status_as_error(false)
        .timeout_global(Some(Duration::from_secs(10)))
        .build()
        .into();
    let mut answer = agent.get(format!("http://{addr}{path}")).call()?;
    let code = answer.status().as_u16();
    Ok((code, answer.body_mut().read_to_string()?))
}

pub fn get_json(addr: &str, path: &str) -> serde_json::Value {
    let (code, body) = http_get(addr, path).expect("HTTP GET");
    assert_eq!(code, 200, "{path}: {body}");
    serde_json::from_str(&body).expect("JSON body")
}

/// Polls `f` every 20 ms until it returns `Some`, or panics after `timeout`.
pub fn wait_for<T>(what: &str, timeout: Duration, mut f: impl FnMut() -> Option<T>) -> T {
    let deadline = Instant::now() + timeout;
    loop {
        if let Some(v) = f() {
            return v;
        }
        assert!(Instant::now() < deadline, "timed out waiting for {what}");
        std::thread::sleep(Duration::from_millis(20));
    }
}

pub fn now_ns() -> u64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_nanos() as u64)
        .unwrap_or(0)
}
