//! The HTTP side of the browser view: one acceptor thread, one thread per connection
//! (a page request ends at once; an event stream lives as long as its client).

use std::collections::VecDeque;
use std::io::{self, Read, Write};
use std::net::{Shutdown, SocketAddr, TcpListener, TcpStream, ToSocketAddrs};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::mpsc::{self, Receiver, RecvTimeoutError, SyncSender, TrySendError};
use std::sync::{Arc, Mutex, MutexGuard};
use std::thread::{self, JoinHandle};
use std::time::Duration;

use super::{page_html, FrameView, ReadingView, WebOptions};
use crate::data::PublishError;

/// How often the acceptor looks for new connections and for the stop flag.
const ACCEPT_POLL: Duration = Duration::from_millis(20);
/// How long a client may take to send its request.
const REQUEST_TIMEOUT: Duration = Duration::from_secs(2);
/// A comment line on an idle event stream, so that a dead client is noticed.
const KEEPALIVE: Duration = Duration::from_secs(15);
/// How far back (in frame time) a newly connected page is sent a module's frames, so
/// that its traces start full; at most [`HISTORY_MAX_FRAMES`] frames and
/// [`HISTORY_MAX_BYTES`] of JSON. An array's page gets the latest frame only.
const HISTORY_NS: u64 = 10_000_000_000;
/// The most frames sent to a newly connected page.
const HISTORY_MAX_FRAMES: usize = 600;
/// The most JSON kept for newly connected pages.
const HISTORY_MAX_BYTES: usize = 8 << 20;
/// Connections open at once (page requests, idle sockets and event streams), as a
/// multiple of [`WebOptions::max_clients`]; a connection beyond is closed at once.
const MAX_CONNECTIONS_PER_CLIENT: usize = 4;
/// The largest request read.
const MAX_REQUEST_BYTES: usize = 8192;
/// No fetch but to this server; inline script and style only.
const CSP: &str = "default-src 'none'; script-src 'unsafe-inline'; style-src 'unsafe-inline'; \
                   connect-src 'self'; img-src data:; base-uri 'none'; form-action 'none'";

/// Counts of the browser view.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct ViewStats {
    /// Event-stream clients connected now.
    pub clients_connected: usize,
    /// Clients dropped because their queue was full (slow or stalled browsers).
    pub clients_dropped_slow: u64,
    /// Clients that went away (closed tab, network error).
    pub clients_disconnected: u64,
    /// Connections refused: an event stream beyond [`WebOptions::max_clients`], or any
    /// connection beyond four times as many open at once.
    pub clients_refused: u64,
    /// Frames pushed.
    pub frames_pushed: u64,
    /// Pages served (`GET /`).
    pub pages_served: u64,
}

struct Client {
    id: u64,
    tx: SyncSender<Arc<str>>,
    stream: TcpStream,
}

#[derive(Default)]
struct State {
    latest: Option<Arc<str>>,
    /// The frames of the last [`HISTORY_NS`] (frame time, JSON), oldest first; the
    /// newest is `latest`.
    recent: VecDeque<(u64, Arc<str>)>,
    clients: Vec<Client>,
    next_id: u64,
    stopped: bool,
}

struct Shared {
    options: WebOptions,
    stop: AtomicBool,
    state: Mutex<State>,
    /// Every accepted connection (a clone, to shut it down) and its thread.
    connections: Mutex<Vec<(TcpStream, JoinHandle<()>)>>,
    dropped_slow: AtomicU64,
    disconnected: AtomicU64,
    refused: AtomicU64,
    frames_pushed: AtomicU64,
    pages_served: AtomicU64,
}

impl Shared {
    fn state(&self) -> MutexGuard<'_, State> {
        self.state.lock().unwrap_or_else(|p| p.into_inner())
    }

    fn connections(&self) -> MutexGuard<'_, Vec<(TcpStream, JoinHandle<()>)>> {
        self.connections.lock().unwrap_or_else(|p| p.into_inner())
    }
}

/// The running browser view (see [`serve`](super::serve)); dropping it stops the server.
pub struct WebView {
    addr: SocketAddr,
    shared: Arc<Shared>,
    acceptor: Option<JoinHandle<()>>,
}

impl std::fmt::Debug for WebView {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("WebView")
            .field("addr", &self.addr)
            .field("stats", &self.stats())
            .finish()
    }
}

impl WebView {
    pub(super) fn start(addr: impl ToSocketAddrs, options: WebOptions) -> io::Result<WebView> {
        let listener = TcpListener::bind(addr)?;
        listener.set_nonblocking(true)?;
        let addr = listener.local_addr()?;
        let shared = Arc::new(Shared {
            options,
            stop: AtomicBool::new(false),
            state: Mutex::new(State::default()),
            connections: Mutex::new(Vec::new()),
            dropped_slow: AtomicU64::new(0),
            disconnected: AtomicU64::new(0),
            refused: AtomicU64::new(0),
            frames_pushed: AtomicU64::new(0),
            pages_served: AtomicU64::new(0),
        });
        let for_thread = Arc::clone(&shared);
        let acceptor = thread::Builder::new()
            .name("fbgforge-web-accept".into())
            .spawn(move || accept_loop(&listener, &for_thread))?;
        Ok(WebView {
            addr,
            shared,
            acceptor: Some(acceptor),
        })
    }

    /// The address served (with the port picked when 0 was asked).
    pub fn local_addr(&self) -> SocketAddr {
        self.addr
    }

    /// `http://ADDR/`, the page's address.
    pub fn url(&self) -> String {
        format!("http://{}/", self.addr)
    }

    /// Sends `frame` to every connected page and keeps it as the latest (served to
    /// pages that connect later). Never blocks on a client: one whose queue is full is
    /// dropped and counted. Fails only when `frame`'s labels and values differ in length.
    pub fn push(&self, frame: &FrameView) -> Result<(), PublishError> {
        let json: Arc<str> = frame.to_json()?.into();
        self.shared.frames_pushed.fetch_add(1, Ordering::Relaxed);
        let mut state = self.shared.state();
        state.latest = Some(Arc::clone(&json));
        let history = matches!(frame.reading, ReadingView::Module(_));
        remember(&mut state.recent, frame.frame_time_ns, &json, history);
        state
            .clients
            .retain(|c| match c.tx.try_send(Arc::clone(&json)) {
                Ok(()) => true,
                Err(TrySendError::Full(_)) => {
                    self.shared.dropped_slow.fetch_add(1, Ordering::Relaxed);
                    // Unblocks its writer if it is stuck in a write; it then ends.
                    let _ = c.stream.shutdown(Shutdown::Both);
                    false
                }
                Err(TrySendError::Disconnected(_)) => {
                    self.shared.disconnected.fetch_add(1, Ordering::Relaxed);
                    false
                }
            });
        Ok(())
    }

    /// Clients and counts.
    pub fn stats(&self) -> ViewStats {
        let s = &self.shared;
        ViewStats {
            clients_connected: s.state().clients.len(),
            clients_dropped_slow: s.dropped_slow.load(Ordering::Relaxed),
            clients_disconnected: s.disconnected.load(Ordering::Relaxed),
            clients_refused: s.refused.load(Ordering::Relaxed),
            frames_pushed: s.frames_pushed.load(Ordering::Relaxed),
            pages_served: s.pages_served.load(Ordering::Relaxed),
        }
    }
}

impl Drop for WebView {
    fn drop(&mut self) {
        self.shared.stop.store(true, Ordering::SeqCst);
        if let Some(a) = self.acceptor.take() {
            let _ = a.join();
        }
        {
            let mut state = self.shared.state();
            state.stopped = true;
            // Dropping the senders ends every writer waiting for a frame.
            state.clients.clear();
        }
        let connections = std::mem::take(&mut *self.shared.connections());
        for (stream, _) in &connections {
            let _ = stream.shutdown(Shutdown::Both);
        }
        for (_, handle) in connections {
            let _ = handle.join();
        }
    }
}

/// Adds the frame `json` at `time_ns`; with `history`, keeps the frames of the last
/// [`HISTORY_NS`] before it (none from before the stream's clock went back), within
/// [`HISTORY_MAX_FRAMES`] and [`HISTORY_MAX_BYTES`]; without, only this one.
fn remember(recent: &mut VecDeque<(u64, Arc<str>)>, time_ns: u64, json: &Arc<str>, history: bool) {
    if !history || recent.back().is_some_and(|&(t, _)| t > time_ns) {
        recent.clear();
    }
    recent.push_back((time_ns, Arc::clone(json)));
    let from = time_ns.saturating_sub(HISTORY_NS);
    let mut bytes: usize = recent.iter().map(|(_, j)| j.len()).sum();
    while recent.len() > 1
        && (recent.len() > HISTORY_MAX_FRAMES
            || bytes > HISTORY_MAX_BYTES
            || recent.front().is_some_and(|&(t, _)| t < from))
    {
        bytes -= recent.pop_front().map_or(0, |(_, j)| j.len());
    }
}

fn accept_loop(listener: &TcpListener, shared: &Arc<Shared>) {
    while !shared.stop.load(Ordering::SeqCst) {
        match listener.accept() {
            Ok((stream, _)) => {
                if let Err(e) = spawn_connection(stream, shared) {
                    eprintln!("fbgforge web view: cannot serve a connection: {e}");
                }
            }
            Err(e) if e.kind() == io::ErrorKind::WouldBlock => thread::sleep(ACCEPT_POLL),
            Err(_) => thread::sleep(ACCEPT_POLL),
        }
        // Forget connections that ended.
        shared.connections().retain(|(_, h)| !h.is_finished());
    }
}

fn spawn_connection(stream: TcpStream, shared: &Arc<Shared>) -> io::Result<()> {
    let limit = shared.options.max_clients.max(1) * MAX_CONNECTIONS_PER_CLIENT;
    if shared.connections().len() >= limit {
        shared.refused.fetch_add(1, Ordering::Relaxed);
        return Ok(()); // dropped: closed at once
    }
    stream.set_nonblocking(false)?;
    stream.set_nodelay(true)?;
    stream.set_read_timeout(Some(REQUEST_TIMEOUT))?;
    stream.set_write_timeout(Some(shared.options.write_timeout))?;
    let clone = stream.try_clone()?;
    let for_thread = Arc::clone(shared);
    let handle = thread::Builder::new()
        .name("fbgforge-web-conn".into())
        .spawn(move || handle_connection(stream, &for_thread))?;
    shared.connections().push((clone, handle));
    Ok(())
}

/// Reads the request head; returns its method and path (query dropped).
fn read_request(stream: &mut TcpStream) -> Option<(String, String)> {
    let mut buf = Vec::with_capacity(1024);
    let mut chunk = [0u8; 1024];
    while !buf.windows(4).any(|w| w == b"\r\n\r\n") && !buf.windows(2).any(|w| w == b"\n\n") {
        if buf.len() >= MAX_REQUEST_BYTES {
            return None;
        }
        let n = stream.read(&mut chunk).ok()?;
        if n == 0 {
            return None;
        }
        buf.extend_from_slice(&chunk[..n]);
    }
    let head = String::from_utf8_lossy(&buf);
    let mut words = head.lines().next()?.split_whitespace();
    let method = words.next()?.to_owned();
    let target = words.next()?;
    let path = target.split(['?', '#']).next().unwrap_or("/").to_owned();
    Some((method, path))
}

fn respond(
    stream: &mut TcpStream,
    status: &str,
    content_type: &str,
    body: &[u8],
) -> io::Result<()> {
    let head = format!(
        "HTTP/1.1 {status}\r\nContent-Type: {content_type}\r\nContent-Length: {}\r\n\
         Cache-Control: no-store\r\nContent-Security-Policy: {CSP}\r\n\
         X-Content-Type-Options: nosniff\r\nConnection: close\r\n\r\n",
        body.len()
    );
    stream.write_all(head.as_bytes())?;
    stream.write_all(body)?;
    stream.flush()
}

fn handle_connection(mut stream: TcpStream, shared: &Arc<Shared>) {
    let Some((method, path)) = read_request(&mut stream) else {
        return;
    };
    if method != "GET" {
        let _ = respond(
            &mut stream,
            "405 Method Not Allowed",
            "text/plain",
            b"GET only\n",
        );
        return;
    }
    let latest = shared.state().latest.clone();
    let _ = match path.as_str() {
        "/" | "/index.html" => {
            shared.pages_served.fetch_add(1, Ordering::Relaxed);
            let page = page_html(latest.as_deref());
            respond(
                &mut stream,
                "200 OK",
                "text/html; charset=utf-8",
                page.as_bytes(),
            )
        }
        "/frame.json" => match latest {
            Some(j) => respond(&mut stream, "200 OK", "application/json", j.as_bytes()),
            None => respond(&mut stream, "204 No Content", "application/json", b""),
        },
        "/events" => {
            event_stream(stream, shared);
            Ok(())
        }
        _ => respond(&mut stream, "404 Not Found", "text/plain", b"not found\n"),
    };
}

/// Registers the client, its queue seeded with the recent frames (the last is the
/// latest), or `None` when the server is stopping or full.
fn register(stream: &TcpStream, shared: &Shared) -> Option<(u64, Receiver<Arc<str>>)> {
    let mut state = shared.state();
    if state.stopped || state.clients.len() >= shared.options.max_clients {
        return None;
    }
    let capacity = shared.options.client_queue_frames.max(1) + state.recent.len();
    let (tx, rx) = mpsc::sync_channel(capacity);
    for (_, frame) in &state.recent {
        tx.try_send(Arc::clone(frame))
            .expect("room for the recent frames");
    }
    let id = state.next_id;
    state.next_id += 1;
    let stream = stream.try_clone().ok()?;
    state.clients.push(Client { id, tx, stream });
    Some((id, rx))
}

fn event_stream(mut stream: TcpStream, shared: &Arc<Shared>) {
    let Some((id, rx)) = register(&stream, shared) else {
        shared.refused.fetch_add(1, Ordering::Relaxed);
        let _ = respond(
            &mut stream,
            "503 Service Unavailable",
            "text/plain",
            b"too many viewers\n",
        );
        return;
    };
    let head = "HTTP/1.1 200 OK\r\nContent-Type: text/event-stream\r\nCache-Control: no-store\r\n\
                X-Accel-Buffering: no\r\nConnection: keep-alive\r\n\r\nretry: 1000\n\n";
    let mut result = stream.write_all(head.as_bytes());
    while result.is_ok() {
        result = match rx.recv_timeout(KEEPALIVE) {
            Ok(frame) => write_event(&mut stream, &frame),
            Err(RecvTimeoutError::Timeout) => stream.write_all(b": keep-alive\n\n"),
            // Dropped as slow by `push`, or the server stops: counted there, if at all.
            Err(RecvTimeoutError::Disconnected) => return,
        };
    }
    let mut state = shared.state();
    let before = state.clients.len();
    state.clients.retain(|c| c.id != id);
    if state.clients.len() < before {
        // Not counted yet: a write that timed out is a slow client, any other error
        // one that went away.
        let slow = result.is_err_and(|e| {
            matches!(
                e.kind(),
                io::ErrorKind::WouldBlock | io::ErrorKind::TimedOut
            )
        });
        let counter = if slow {
            &shared.dropped_slow
        } else {
            &shared.disconnected
        };
        counter.fetch_add(1, Ordering::Relaxed);
    }
}

fn write_event(stream: &mut TcpStream, json: &str) -> io::Result<()> {
    let mut msg = Vec::with_capacity(json.len() + 8);
    msg.extend_from_slice(b"data: ");
    msg.extend_from_slice(json.as_bytes());
    msg.extend_from_slice(b"\n\n");
    stream.write_all(&msg)?;
    stream.flush()
}
