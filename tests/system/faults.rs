//! Faults a match day brings, with the real processes: a server killed and restarted under
//! its robots, and a recording disk that fills up and then has room again. Loopback only;
//! every wait is bounded.

mod support;

use fusion_server::read_log;
use std::path::Path;
use std::process::Command;
use std::time::{Duration, Instant};
use support::*;

/// A `sim_robots` process of five robots feeding `endpoint` for `seconds`.
fn robots(endpoint: &str, seconds: f64) -> Proc {
    let start = proto::Stamp(now_ns()).offset_secs(1.0).0.to_string();
    Proc::robots(&[
        "--connect",
        endpoint,
        "--scenario",
        "match",
        "--seed",
        "3",
        "--duration-s",
        &seconds.to_string(),
        "--start-ns",
        &start,
    ])
}

fn accepted(addr: &str) -> f64 {
    metric(addr, "rf_observations_accepted_total")
}

/// A labelled sample of `/metrics`, e.g. `rf_record_errors_total{cause="disk_full"}`.
fn labelled(addr: &str, sample: &str) -> f64 {
    let (_, text) = http_get(addr, "/metrics").expect("metrics");
    text.lines()
        .find_map(|l| l.strip_prefix(&format!("{sample} ")))
        .and_then(|v| v.trim().parse().ok())
        .unwrap_or(0.0)
}

#[test]
fn robots_are_back_soon_after_a_killed_server_listens_again() {
    let (mut server, endpoint, addr) = start_server(&[]);
    let _robots = robots(&endpoint, 60.0);
    wait_for("observations", Duration::from_secs(60), || {
        (accepted(&addr) > 50.0).then_some(())
    });
    server.child.kill().expect("kill -9");
    let _ = server.child.wait();
    // Down for a while: the robots keep trying, at most twice a second.
    std::thread::sleep(Duration::from_millis(1500));
    let port = endpoint.rsplit(':').next().expect("port").to_string();
    let restarted = Proc::spawn(&[
        "serve",
        "--open",
        "--listen",
        &format!("tcp/127.0.0.1:{port}"),
        "--http",
        "127.0.0.1:0",
    ]);
    let addr = http_addr(&restarted);
    let listening = Instant::now();
    wait_for("the robots back", Duration::from_secs(20), || {
        (accepted(&addr) > 0.0).then_some(())
    });
    let back_s = listening.elapsed().as_secs_f64();
    println!("robots back {back_s:.2} s after the restarted server listened");
    // Loosely: the target is 1 s (the figure in docs/operations.md is this test's output,
    // `cargo test -p system-tests --test faults -- --nocapture`); a loaded test machine
    // must not fail it.
    assert!(back_s < 3.0, "robots back only after {back_s:.2} s");
}

/// Runs `script` in a mount namespace of its own (as root, or as a user mapped to root),
/// where it may mount a tmpfs; `None` when this machine allows neither.
fn in_mount_namespace(script: &str, probe: &Path) -> Option<Proc> {
    let root = Command::new("id")
        .arg("-u")
        .output()
        .is_ok_and(|o| String::from_utf8_lossy(&o.stdout).trim() == "0");
    let flags: &[&str] = if root { &["-m"] } else { &["-r", "-m"] };
    let works = Command::new("unshare")
        .args(flags)
        .args(["sh", "-c", "mount -t tmpfs -o size=1m tmpfs \"$1\"", "sh"])
        .arg(probe)
        .status()
        .is_ok_and(|s| s.success());
    if !works {
        return None;
    }
    let mut args: Vec<&str> = flags.to_vec();
    args.extend(["sh", "-c", script]);
    Some(Proc::spawn_bin(Path::new("unshare"), &args))
}

#[test]
fn a_full_disk_stops_the_recording_loudly_and_it_resumes_when_there_is_room() {
    let ctl = temp_dir("disk-full");
    let disk = ctl.join("disk");
    std::fs::create_dir_all(&disk).expect("mount point");
    let port = proto::net::free_loopback_port().expect("free port");
    let endpoint = format!("tcp/127.0.0.1:{port}");
    // A 4 MB tmpfs nearly filled; the server records there; the test frees the room and
    // stops the server through files in `ctl`, and the logs are copied out at the end.
    let script = format!(
        r#"set -e
mount -t tmpfs -o size=4m tmpfs "{disk}"
head -c 3400000 /dev/zero > "{disk}/filler"
"{server}" serve --open --listen {endpoint} --http 127.0.0.1:0 --record "{disk}/logs" &
pid=$!
while [ ! -e "{ctl}/free" ]; do sleep 0.05; done
rm -f "{disk}/filler"
while [ ! -e "{ctl}/stop" ]; do sleep 0.05; done
kill -TERM $pid
wait $pid || true
cp -r "{disk}/logs" "{ctl}/logs"
"#,
        disk = disk.display(),
        ctl = ctl.display(),
        server = server_bin().display(),
    );
    let Some(mut ns) = in_mount_namespace(&script, &disk) else {
        println!("skipped: this machine allows no mount namespace for a small tmpfs");
        return;
    };
    let addr = http_addr(&ns);
    let _robots = robots(&endpoint, 90.0);

    // The disk fills: the recording stops, says why, and the ball is still served.
    wait_for("the recording to stop", Duration::from_secs(60), || {
        (metric(&addr, "rf_record_stopped") == 1.0).then_some(())
    });
    assert!(labelled(&addr, r#"rf_record_errors_total{cause="disk_full"}"#) >= 1.0);
    let state = get_json(&addr, "/api/state");
    let rec = &state["recording"];
    assert_eq!(rec["stopped"], true, "{rec}");
    assert_eq!(rec["cause"], "disk_full", "{rec}");
    assert!(
        rec["reason"]
            .as_str()
            .is_some_and(|r| r.contains("the disk is full")),
        "{rec}"
    );
    let published = metric(&addr, "rf_states_published_total");
    wait_for(
        "states served while stopped",
        Duration::from_secs(10),
        || (metric(&addr, "rf_states_published_total") > published + 10.0).then_some(()),
    );
    let lost = |addr: &str| metric(addr, "rf_record_failed_total");
    wait_for(
        "messages counted as not recorded",
        Duration::from_secs(10),
        || (lost(&addr) > 0.0).then_some(()),
    );

    // A try at a new file on the still full disk fails too (and leaves no file behind).
    wait_for(
        "a failed try at a new file",
        Duration::from_secs(15),
        || (labelled(&addr, r#"rf_record_errors_total{cause="disk_full"}"#) >= 2.0).then_some(()),
    );

    // Room again: recording resumes into a new file within a few seconds.
    std::fs::write(ctl.join("free"), b"").expect("free the disk");
    let freed = Instant::now();
    wait_for("the recording to resume", Duration::from_secs(20), || {
        (metric(&addr, "rf_record_stopped") == 0.0
            && metric(&addr, "rf_record_resumed_total") >= 1.0)
            .then_some(())
    });
    println!(
        "recording resumed {:.2} s after the disk had room",
        freed.elapsed().as_secs_f64()
    );
    let recorded = metric(&addr, "rf_record_messages_total");
    wait_for("messages recorded again", Duration::from_secs(10), || {
        (metric(&addr, "rf_record_messages_total") > recorded + 10.0).then_some(())
    });
    std::fs::write(ctl.join("stop"), b"").expect("stop");
    wait_for("the server to stop", Duration::from_secs(30), || {
        ns.child.try_wait().ok().flatten()
    });

    // Both files open: the one the full disk cut short up to its last flush, the one after
    // complete.
    let files = mcap_files(&ctl.join("logs"));
    assert!(files.len() >= 2, "{files:?}");
    // No empty file left by a try on the full disk: every one opens.
    for f in &files {
        read_log(f).unwrap_or_else(|e| panic!("{}: {e}", f.display()));
    }
    let first = read_log(&files[0]).expect("the file the disk cut short opens");
    assert!(first.messages.len() > 10, "{}", first.messages.len());
    let last = read_log(&files[files.len() - 1]).expect("the file after opens");
    assert!(last.complete, "{:?}", last.problem);
    assert!(last.messages.len() > 10);
    let _ = std::fs::remove_dir_all(&ctl);
}

/// A userspace TCP proxy between robots and the server (this kernel has no netem): it
/// forwards each connection both ways, and on demand delays what the robots send (order
/// kept), cuts every connection at once, or refuses all for a while (a partition).
mod proxy {
    use std::io::{Read, Write};
    use std::net::{Shutdown, TcpListener, TcpStream};
    use std::sync::atomic::{AtomicBool, AtomicU64, Ordering::Relaxed};
    use std::sync::{Arc, Mutex};
    use std::time::{Duration, Instant};

    #[derive(Default)]
    struct State {
        /// Refusing every connection, and cutting those that come.
        partitioned: AtomicBool,
        /// Most delay of the robots' bytes, ms (0: none); each chunk waits 0 to this long.
        jitter_ms: AtomicU64,
        streams: Mutex<Vec<TcpStream>>,
        stop: AtomicBool,
    }

    pub struct FaultProxy {
        pub port: u16,
        state: Arc<State>,
    }

    impl FaultProxy {
        /// A proxy on a free loopback port to `upstream` (a port on 127.0.0.1).
        pub fn start(upstream: u16) -> FaultProxy {
            let listener = TcpListener::bind("127.0.0.1:0").expect("proxy port");
            let port = listener.local_addr().expect("address").port();
            listener.set_nonblocking(true).expect("non-blocking");
            let state = Arc::new(State::default());
            let s = state.clone();
            std::thread::spawn(move || {
                while !s.stop.load(Relaxed) {
                    match listener.accept() {
                        Ok((client, _)) => {
                            let _ = client.set_nonblocking(false);
                            if s.partitioned.load(Relaxed) {
                                let _ = client.shutdown(Shutdown::Both);
                                continue;
                            }
                            if let Ok(server) = TcpStream::connect(("127.0.0.1", upstream)) {
                                connect(&s, client, server);
                            }
                        }
                        Err(_) => std::thread::sleep(Duration::from_millis(5)),
                    }
                }
            });
            FaultProxy { port, state }
        }

        /// Delays every chunk the robots send by 0 to `max_ms` (0: no delay).
        pub fn jitter(&self, max_ms: u64) {
            self.state.jitter_ms.store(max_ms, Relaxed);
        }

        /// Cuts every connection at once (both ends see a reset).
        pub fn reset(&self) {
            for s in self.state.streams.lock().expect("streams").drain(..) {
                let _ = s.shutdown(Shutdown::Both);
            }
        }

        /// Cuts every connection and refuses new ones while `on`.
        pub fn partition(&self, on: bool) {
            self.state.partitioned.store(on, Relaxed);
            if on {
                self.reset();
            }
        }
    }

    impl Drop for FaultProxy {
        fn drop(&mut self) {
            self.state.stop.store(true, Relaxed);
            self.reset();
        }
    }

    fn connect(s: &Arc<State>, client: TcpStream, server: TcpStream) {
        let (Ok(c2), Ok(s2)) = (client.try_clone(), server.try_clone()) else {
            return;
        };
        {
            let mut streams = s.streams.lock().expect("streams");
            streams.extend(client.try_clone().ok());
            streams.extend(server.try_clone().ok());
        }
        let up = s.clone();
        std::thread::spawn(move || pump(client, s2, Some(up)));
        std::thread::spawn(move || pump(server, c2, None));
    }

    /// Copies `from` to `to` until either closes; with `jitter`, each chunk is held back
    /// 0 to the current most delay, never overtaking the one before.
    fn pump(mut from: TcpStream, mut to: TcpStream, jitter: Option<Arc<State>>) {
        let mut buf = vec![0u8; 64 << 10];
        let mut released = Instant::now();
        let mut seed = 0x9e37_79b9_7f4a_7c15_u64;
        loop {
            let n = match from.read(&mut buf) {
                Ok(0) | Err(_) => break,
                Ok(n) => n,
            };
            if let Some(s) = &jitter {
                let max_ms = s.jitter_ms.load(Relaxed);
                if max_ms > 0 {
                    seed ^= seed << 13;
                    seed ^= seed >> 7;
                    seed ^= seed << 17;
                    let delay = Duration::from_millis(seed % (max_ms + 1));
                    released = released.max(Instant::now() + delay);
                    std::thread::sleep(released.saturating_duration_since(Instant::now()));
                }
            }
            if to.write_all(&buf[..n]).is_err() {
                break;
            }
        }
        let _ = from.shutdown(Shutdown::Both);
        let _ = to.shutdown(Shutdown::Both);
    }
}

/// Seconds until the server accepts observations again after `since`.
fn back_after(addr: &str, since: Instant) -> f64 {
    let before = accepted(addr);
    wait_for("observations again", Duration::from_secs(30), || {
        (accepted(addr) > before + 5.0).then_some(())
    });
    since.elapsed().as_secs_f64()
}

#[test]
fn through_jitter_resets_and_a_ten_second_partition_the_robots_keep_coming_back() {
    let (_server, endpoint, addr) = start_server(&[]);
    let upstream: u16 = endpoint
        .rsplit(':')
        .next()
        .and_then(|p| p.parse().ok())
        .expect("port");
    let proxy = proxy::FaultProxy::start(upstream);
    let _robots = robots(&format!("tcp/127.0.0.1:{}", proxy.port), 90.0);
    wait_for(
        "observations through the proxy",
        Duration::from_secs(60),
        || (accepted(&addr) > 50.0).then_some(()),
    );

    // 0 to 200 ms of delay on everything the robots send: observations still flow and are
    // fused (a few may come too late for the fusion's window, and are counted).
    let rate = |secs: u64| {
        let (before, t0) = (accepted(&addr), Instant::now());
        std::thread::sleep(Duration::from_secs(secs));
        (accepted(&addr) - before) / t0.elapsed().as_secs_f64()
    };
    let clean_hz = rate(3);
    proxy.jitter(200);
    let jitter_hz = rate(4);
    proxy.jitter(0);
    println!(
        "observations fused a second: {clean_hz:.0} clean, {jitter_hz:.0} under 100 ± 100 ms of jitter"
    );
    assert!(
        jitter_hz > 0.5 * clean_hz,
        "{jitter_hz} a second under jitter against {clean_hz} clean"
    );

    // Every link reset at once.
    let cut = Instant::now();
    proxy.reset();
    let after_reset_s = back_after(&addr, cut);
    println!("every link reset: observations again after {after_reset_s:.2} s");
    assert!(after_reset_s < 3.0, "{after_reset_s}");

    // Cut off for ten seconds, then the network heals.
    proxy.partition(true);
    std::thread::sleep(Duration::from_secs(10));
    let healed = Instant::now();
    proxy.partition(false);
    let after_partition_s = back_after(&addr, healed);
    println!("after a 10 s partition: observations again {after_partition_s:.2} s after it healed");
    assert!(after_partition_s < 3.0, "{after_partition_s}");
    let state = get_json(&addr, "/api/state");
    assert!(
        state["ball"].is_object(),
        "the ball is served again: {state}"
    );
}
