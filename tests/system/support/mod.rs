//! Running the fusion server and simulated robots as processes in tests:
//! child processes that die with the test, the addresses they print, and a minimal HTTP
//! client.

#![allow(dead_code)]

use std::io::{BufRead, BufReader};
use std::process::{Child, Command, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant};

/// Simulated robots (`sim_robots`).
pub const SIM_ROBOTS: &str = env!("CARGO_BIN_EXE_system-sim-robots");
/// The match-log writer of simulated matches (`simulate`).
pub const SIMULATE: &str = env!("CARGO_BIN_EXE_system-simulate");
/// The fusion server (`fusion-server`).
pub const SERVER: &str = env!("CARGO_BIN_EXE_system-fusion-server");

/// The fusion server's binary.
pub fn server_bin() -> std::path::PathBuf {
    std::path::PathBuf::from(SERVER)
}

/// A child process killed (SIGKILL) when dropped.
#[derive(Debug)]
pub struct Proc {
    pub child: Child,
    pub lines: mpsc::Receiver<String>,
}

impl Proc {
    /// The server with `args`.
    pub fn spawn(args: &[&str]) -> Proc {
        Proc::spawn_bin(&server_bin(), args)
    }

    /// Simulated robots with `args`.
    pub fn robots(args: &[&str]) -> Proc {
        Proc::spawn_bin(std::path::Path::new(SIM_ROBOTS), args)
    }

    pub fn spawn_bin(bin: &std::path::Path, args: &[&str]) -> Proc {
        let mut child = Command::new(bin)
            .args(args)
            .env("RUST_LOG", "warn,zenoh=error")
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit())
            .spawn()
            .unwrap_or_else(|e| panic!("spawn {}: {e}", bin.display()));
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

/// Starts a server on a free Zenoh port and an OS-chosen HTTP port; returns it, its Zenoh
/// endpoint and its HTTP address.
pub fn start_server(extra: &[&str]) -> (Proc, String, String) {
    let port = proto::net::free_loopback_port().expect("free port");
    let endpoint = format!("tcp/127.0.0.1:{port}");
    let mut args = vec![
        "serve",
        "--open",
        "--listen",
        &endpoint,
        "--http",
        "127.0.0.1:0",
    ];
    args.extend_from_slice(extra);
    let p = Proc::spawn(&args);
    let addr = http_addr(&p);
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

/// A fresh temporary folder for one test (emptied if an earlier run left it).
pub fn temp_dir(name: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("rf-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("temp dir");
    dir
}

/// The `.mcap` files in `dir`, sorted.
pub fn mcap_files(dir: &std::path::Path) -> Vec<std::path::PathBuf> {
    let mut files: Vec<std::path::PathBuf> = std::fs::read_dir(dir)
        .expect("log dir")
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "mcap"))
        .collect();
    files.sort();
    files
}

/// The value of the unlabelled sample `name` in the server's `/metrics` (0 when absent).
pub fn metric(addr: &str, name: &str) -> f64 {
    let (_, text) = http_get(addr, "/metrics").expect("metrics");
    text.lines()
        .find_map(|l| l.strip_prefix(&format!("{name} ")))
        .and_then(|v| v.trim().parse().ok())
        .unwrap_or(0.0)
}

/// The `http://ADDR/` line a server prints, as `ADDR`.
pub fn http_addr(p: &Proc) -> String {
    let url = p.line_starting("http://", Duration::from_secs(30));
    url.trim_start_matches("http://")
        .trim_end_matches('/')
        .to_string()
}
