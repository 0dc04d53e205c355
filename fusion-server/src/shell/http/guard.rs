//! The HTTP listener's guard: a cap on open connections, and deadlines on each one, so
//! that slow or stuck clients cannot hold the server's sockets and memory.
//!
//! - **Connection cap**: at `max_connections`, a new connection takes the place of the
//!   connection idle the longest (no request in progress, nothing moved for a second), which
//!   is closed (counted); when none is idle, the new one is closed at once (counted). The
//!   cap itself is derived from the open-files limit ([`fd_limits`]).
//! - **Request deadline**: once a client has sent anything, the server must have started
//!   its answer within `request_timeout_s`, or the connection is closed: a client sending
//!   its headers a byte at a time (slowloris) is cut off.
//! - **Idle deadline**: a connection on which nothing moves either way for
//!   `idle_timeout_s` is closed, also one whose client stopped reading what the server
//!   writes.

use std::collections::HashMap;
use std::io;
use std::net::SocketAddr;
use std::pin::Pin;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering::Relaxed};
use std::sync::{Arc, Mutex};
use std::task::{Context, Poll, Waker};
use std::time::Duration;
use tokio::io::{AsyncRead, AsyncWrite, ReadBuf};
use tokio::net::{TcpListener, TcpStream};
use tokio::sync::{OwnedSemaphorePermit, Semaphore};
use tokio::time::{Instant, Sleep};

/// Bounds on the HTTP side of the server.
#[derive(Debug, Clone, PartialEq)]
pub struct HttpLimits {
    /// Connections open at once (WebSocket streams included).
    pub max_connections: usize,
    /// From a client's first byte of a request to the start of the server's answer.
    pub request_timeout_s: f64,
    /// Nothing read or written for this long closes the connection.
    pub idle_timeout_s: f64,
    /// A live-stream frame not handed to the client within this time drops the client.
    pub ws_send_timeout_s: f64,
}

impl Default for HttpLimits {
    fn default() -> Self {
        HttpLimits {
            max_connections: 4096,
            request_timeout_s: 10.0,
            idle_timeout_s: 60.0,
            ws_send_timeout_s: 5.0,
        }
    }
}

/// What the guard counts.
#[derive(Debug, Default)]
pub struct GuardStats {
    pub open: AtomicU64,
    /// Connections closed at once because `max_connections` were open and none was idle.
    pub refused: AtomicU64,
    /// Idle connections closed to make room for a new one, `max_connections` being open.
    pub idle_evicted: AtomicU64,
    /// Connections closed by the request deadline.
    pub request_timeouts: AtomicU64,
    /// Connections closed by the idle deadline.
    pub idle_timeouts: AtomicU64,
}

/// Descriptors kept for everything but HTTP: Zenoh's links, the match log, the runtime.
pub const FD_RESERVE: u64 = 128;
/// The fewest HTTP connections the cap allows, whatever the limit.
const MIN_CONNECTIONS: usize = 16;
/// A connection is idle, and may be closed for a newcomer, after this long without traffic
/// and with no request in progress.
const EVICTABLE_AFTER: Duration = Duration::from_secs(1);
/// How long a newcomer waits for the room an evicted connection leaves.
const EVICTION_WAIT: Duration = Duration::from_millis(500);

/// The process's open-files limit, raised to its hard limit.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FdLimits {
    pub soft_before: u64,
    pub soft: u64,
    pub hard: u64,
}

/// Raises the open-files soft limit to the hard one (where the system allows it).
pub fn fd_limits() -> Option<FdLimits> {
    let (soft_before, hard) = rlimit::getrlimit(rlimit::Resource::NOFILE).ok()?;
    let soft = match rlimit::setrlimit(rlimit::Resource::NOFILE, hard, hard) {
        Ok(()) => hard,
        Err(e) => {
            tracing::warn!("raising the open-files limit from {soft_before} to {hard}: {e}");
            soft_before
        }
    };
    Some(FdLimits {
        soft_before,
        soft,
        hard,
    })
}

/// The HTTP connection cap under an open-files limit of `soft`: the configured cap, but
/// never within [`FD_RESERVE`] of the limit.
pub fn connection_cap(configured: usize, soft: u64) -> usize {
    let room = usize::try_from(soft.saturating_sub(FD_RESERVE)).unwrap_or(usize::MAX);
    configured.min(room.max(MIN_CONNECTIONS)).max(1)
}

/// What the listener knows of one open connection.
#[derive(Debug)]
struct Conn {
    /// Milliseconds since the listener started, at its last traffic.
    active_ms: AtomicU64,
    /// A request is in progress (read, not yet answered).
    busy: AtomicBool,
    /// Set to close it for a newcomer.
    kill: AtomicBool,
    /// Wakes its task when it is to be closed.
    waker: Mutex<Option<Waker>>,
}

/// The open connections, for choosing which idle one to close.
#[derive(Debug, Default)]
struct Conns {
    next: AtomicU64,
    open: Mutex<HashMap<u64, Arc<Conn>>>,
}

impl Conns {
    /// Marks the connection idle the longest (at least [`EVICTABLE_AFTER`]) for closing.
    fn evict_idlest(&self, now_ms: u64) -> bool {
        let open = self.open.lock().unwrap_or_else(|p| p.into_inner());
        let idle_ms = EVICTABLE_AFTER.as_millis() as u64;
        let victim = open
            .values()
            .filter(|c| !c.busy.load(Relaxed) && !c.kill.load(Relaxed))
            .filter(|c| now_ms.saturating_sub(c.active_ms.load(Relaxed)) >= idle_ms)
            .min_by_key(|c| c.active_ms.load(Relaxed));
        let Some(victim) = victim else { return false };
        victim.kill.store(true, Relaxed);
        if let Some(w) = victim
            .waker
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .take()
        {
            w.wake();
        }
        true
    }
}

/// A [`TcpListener`] that caps connections and hands out [`GuardedStream`]s.
#[derive(Debug)]
pub struct GuardedListener {
    inner: TcpListener,
    conns: Arc<Conns>,
    started: Instant,
    permits: Arc<Semaphore>,
    request_timeout: Duration,
    idle_timeout: Duration,
    stats: Arc<GuardStats>,
}

/// A timeout in seconds as a `Duration`, kept within 1 ms..1 day (so that a deadline never
/// overflows the clock).
pub fn secs(s: f64) -> Duration {
    let s = if s.is_nan() { 1.0 } else { s };
    Duration::from_secs_f64(s.clamp(1e-3, 86_400.0))
}

impl GuardedListener {
    pub fn new(inner: TcpListener, limits: &HttpLimits, stats: Arc<GuardStats>) -> Self {
        GuardedListener {
            inner,
            conns: Arc::new(Conns::default()),
            started: Instant::now(),
            permits: Arc::new(Semaphore::new(limits.max_connections.max(1))),
            request_timeout: secs(limits.request_timeout_s),
            idle_timeout: secs(limits.idle_timeout_s),
            stats,
        }
    }
}

impl axum::serve::Listener for GuardedListener {
    type Io = GuardedStream;
    type Addr = SocketAddr;

    async fn accept(&mut self) -> (Self::Io, Self::Addr) {
        loop {
            let (stream, addr) = match self.inner.accept().await {
                Ok(s) => s,
                Err(e) => {
                    // Out of descriptors and the like: wait rather than spin.
                    tracing::warn!("accepting an HTTP connection failed: {e}");
                    tokio::time::sleep(Duration::from_millis(50)).await;
                    continue;
                }
            };
            let permit = match Arc::clone(&self.permits).try_acquire_owned() {
                Ok(p) => Some(p),
                // Full: the longest-idle connection makes room, if there is one.
                Err(_) if self.conns.evict_idlest(ms_since(self.started)) => {
                    self.stats.idle_evicted.fetch_add(1, Relaxed);
                    let acquire = Arc::clone(&self.permits).acquire_owned();
                    tokio::time::timeout(EVICTION_WAIT, acquire)
                        .await
                        .ok()
                        .and_then(Result::ok)
                }
                Err(_) => None,
            };
            let Some(permit) = permit else {
                self.stats.refused.fetch_add(1, Relaxed);
                drop(stream);
                continue;
            };
            self.stats.open.fetch_add(1, Relaxed);
            let now = Instant::now();
            let id = self.conns.next.fetch_add(1, Relaxed);
            let conn = Arc::new(Conn {
                active_ms: AtomicU64::new(ms_since(self.started)),
                busy: AtomicBool::new(false),
                kill: AtomicBool::new(false),
                waker: Mutex::new(None),
            });
            self.conns
                .open
                .lock()
                .unwrap_or_else(|p| p.into_inner())
                .insert(id, conn.clone());
            let io = GuardedStream {
                inner: stream,
                conns: self.conns.clone(),
                id,
                conn,
                started: self.started,
                _permit: permit,
                stats: Arc::clone(&self.stats),
                request_timeout: self.request_timeout,
                idle_timeout: self.idle_timeout,
                idle_at: now + self.idle_timeout,
                answer_by: None,
                timer: Box::pin(tokio::time::sleep_until(now + self.idle_timeout)),
            };
            return (io, addr);
        }
    }

    fn local_addr(&self) -> io::Result<Self::Addr> {
        self.inner.local_addr()
    }
}

fn ms_since(start: Instant) -> u64 {
    start.elapsed().as_millis() as u64
}

/// A connection under the guard's deadlines.
#[derive(Debug)]
pub struct GuardedStream {
    inner: TcpStream,
    conns: Arc<Conns>,
    id: u64,
    conn: Arc<Conn>,
    started: Instant,
    _permit: OwnedSemaphorePermit,
    stats: Arc<GuardStats>,
    request_timeout: Duration,
    idle_timeout: Duration,
    idle_at: Instant,
    /// Set when the client sent something the server has not started to answer.
    answer_by: Option<Instant>,
    timer: Pin<Box<Sleep>>,
}

impl Drop for GuardedStream {
    fn drop(&mut self) {
        self.stats.open.fetch_sub(1, Relaxed);
        self.conns
            .open
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .remove(&self.id);
    }
}

impl GuardedStream {
    fn deadline(&self) -> Instant {
        self.answer_by.map_or(self.idle_at, |a| a.min(self.idle_at))
    }

    fn rearm(&mut self) {
        let d = self.deadline();
        if self.timer.deadline() != d {
            self.timer.as_mut().reset(d);
        }
    }

    /// Traffic just now, `busy` when a request is in progress.
    fn moved(&self, busy: bool) {
        self.conn.active_ms.store(ms_since(self.started), Relaxed);
        self.conn.busy.store(busy, Relaxed);
    }

    /// Closed to make room for a newcomer.
    fn evicted(&self) -> Option<io::Error> {
        self.conn.kill.load(Relaxed).then(|| {
            io::Error::new(
                io::ErrorKind::ConnectionAborted,
                "closed for a new connection, being idle the longest",
            )
        })
    }

    /// After the inner stream said Pending: an error if a deadline has passed or the
    /// connection is to make room (the timer is polled and the waker kept, so the task
    /// wakes for either).
    fn check(&mut self, cx: &mut Context<'_>) -> Poll<io::Error> {
        *self.conn.waker.lock().unwrap_or_else(|p| p.into_inner()) = Some(cx.waker().clone());
        if let Some(e) = self.evicted() {
            return Poll::Ready(e);
        }
        self.rearm();
        if self.timer.as_mut().poll(cx).is_pending() {
            return Poll::Pending;
        }
        let now = Instant::now();
        let (counter, what) = if self.answer_by.is_some_and(|a| a <= now) {
            (&self.stats.request_timeouts, "request")
        } else {
            (&self.stats.idle_timeouts, "idle")
        };
        counter.fetch_add(1, Relaxed);
        Poll::Ready(io::Error::new(
            io::ErrorKind::TimedOut,
            format!("HTTP {what} timeout"),
        ))
    }
}

impl AsyncRead for GuardedStream {
    fn poll_read(
        mut self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        buf: &mut ReadBuf<'_>,
    ) -> Poll<io::Result<()>> {
        if let Some(e) = self.evicted() {
            return Poll::Ready(Err(e));
        }
        let before = buf.filled().len();
        match Pin::new(&mut self.inner).poll_read(cx, buf) {
            Poll::Ready(Ok(())) => {
                if buf.filled().len() > before {
                    let now = Instant::now();
                    self.idle_at = now + self.idle_timeout;
                    if self.answer_by.is_none() {
                        self.answer_by = Some(now + self.request_timeout);
                    }
                    self.moved(true);
                }
                Poll::Ready(Ok(()))
            }
            Poll::Ready(Err(e)) => Poll::Ready(Err(e)),
            Poll::Pending => self.check(cx).map(Err),
        }
    }
}

impl AsyncWrite for GuardedStream {
    fn poll_write(
        mut self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        data: &[u8],
    ) -> Poll<io::Result<usize>> {
        if let Some(e) = self.evicted() {
            return Poll::Ready(Err(e));
        }
        match Pin::new(&mut self.inner).poll_write(cx, data) {
            Poll::Ready(Ok(n)) => {
                if n > 0 {
                    self.idle_at = Instant::now() + self.idle_timeout;
                    self.answer_by = None;
                    self.moved(false);
                }
                Poll::Ready(Ok(n))
            }
            Poll::Ready(Err(e)) => Poll::Ready(Err(e)),
            Poll::Pending => self.check(cx).map(Err),
        }
    }

    fn poll_flush(mut self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<io::Result<()>> {
        match Pin::new(&mut self.inner).poll_flush(cx) {
            Poll::Pending => self.check(cx).map(Err),
            done => done,
        }
    }

    fn poll_shutdown(mut self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<io::Result<()>> {
        Pin::new(&mut self.inner).poll_shutdown(cx)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_cap_keeps_a_reserve_of_descriptors() {
        assert_eq!(connection_cap(4096, 1_048_576), 4096);
        assert_eq!(connection_cap(4096, 256), 128);
        assert_eq!(connection_cap(100, 256), 100);
        assert_eq!(connection_cap(4, 1_048_576), 4);
        // Never below a handful, however low the limit.
        assert_eq!(connection_cap(4096, 64), MIN_CONNECTIONS);
    }

    #[test]
    fn the_idlest_quiet_connection_is_chosen_and_busy_ones_are_kept() {
        let conns = Conns::default();
        let add = |id: u64, active_ms: u64, busy: bool| {
            let c = Arc::new(Conn {
                active_ms: AtomicU64::new(active_ms),
                busy: AtomicBool::new(busy),
                kill: AtomicBool::new(false),
                waker: Mutex::new(None),
            });
            conns.open.lock().expect("lock").insert(id, c.clone());
            c
        };
        let busy_old = add(1, 0, true);
        let idle_old = add(2, 100, false);
        let idle_new = add(3, 5_000, false);
        // At 5.5 s only the one idle for a second or more goes; then nobody.
        assert!(conns.evict_idlest(5_500));
        assert!(idle_old.kill.load(Relaxed));
        assert!(!busy_old.kill.load(Relaxed) && !idle_new.kill.load(Relaxed));
        assert!(!conns.evict_idlest(5_500));
        assert!(conns.evict_idlest(6_100));
        assert!(idle_new.kill.load(Relaxed));
    }
}
