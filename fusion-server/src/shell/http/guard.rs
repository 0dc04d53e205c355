//! The HTTP listener's guard: a cap on open connections, and deadlines on each one, so
//! that slow or stuck clients cannot hold the server's sockets and memory.
//!
//! - **Connection cap**: beyond `max_connections`, new connections are closed at once
//!   (counted).
//! - **Request deadline**: once a client has sent anything, the server must have started
//!   its answer within `request_timeout_s`, or the connection is closed: a client sending
//!   its headers a byte at a time (slowloris) is cut off.
//! - **Idle deadline**: a connection on which nothing moves either way for
//!   `idle_timeout_s` is closed, also one whose client stopped reading what the server
//!   writes.

use std::io;
use std::net::SocketAddr;
use std::pin::Pin;
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering::Relaxed};
use std::task::{Context, Poll};
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
            max_connections: 256,
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
    /// Connections closed at once because `max_connections` were open.
    pub refused: AtomicU64,
    /// Connections closed by the request deadline.
    pub request_timeouts: AtomicU64,
    /// Connections closed by the idle deadline.
    pub idle_timeouts: AtomicU64,
}

/// A [`TcpListener`] that caps connections and hands out [`GuardedStream`]s.
#[derive(Debug)]
pub struct GuardedListener {
    inner: TcpListener,
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
            let Ok(permit) = Arc::clone(&self.permits).try_acquire_owned() else {
                self.stats.refused.fetch_add(1, Relaxed);
                drop(stream);
                continue;
            };
            self.stats.open.fetch_add(1, Relaxed);
            let now = Instant::now();
            let io = GuardedStream {
                inner: stream,
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

/// A connection under the guard's deadlines.
#[derive(Debug)]
pub struct GuardedStream {
    inner: TcpStream,
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

    /// After the inner stream said Pending: an error if a deadline has passed (the timer
    /// is polled, so the task wakes when it does).
    fn check(&mut self, cx: &mut Context<'_>) -> Poll<io::Error> {
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
        let before = buf.filled().len();
        match Pin::new(&mut self.inner).poll_read(cx, buf) {
            Poll::Ready(Ok(())) => {
                if buf.filled().len() > before {
                    let now = Instant::now();
                    self.idle_at = now + self.idle_timeout;
                    if self.answer_by.is_none() {
                        self.answer_by = Some(now + self.request_timeout);
                    }
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
        match Pin::new(&mut self.inner).poll_write(cx, data) {
            Poll::Ready(Ok(n)) => {
                if n > 0 {
                    self.idle_at = Instant::now() + self.idle_timeout;
                    self.answer_by = None;
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
