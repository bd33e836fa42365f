use std::io::{Read, Write};
use std::net::{SocketAddr, TcpStream};
use std::time::{Duration, Instant};

use super::*;

fn array_frame(load_b_g: f64, label_len: usize) -> FrameView {
    let mut labels: Vec<String> = ["A", "B", "C", "D", "E", "F", "G", "H"]
        .iter()
        .map(|s| s.to_string())
        .collect();
    if label_len > 1 {
        labels[7] = "H".repeat(label_len);
    }
    let mut loads = vec![0.0; 8];
    loads[1] = load_b_g;
    FrameView {
        design_name: "tactile-array-60x80".into(),
        frame_time_ns: 2_500_000_000,
        reading: ReadingView::Array(ArrayView {
            nx: 4,
            ny: 2,
            cell_labels: labels,
            cell_loads: loads,
            load_unit: LoadUnit::Grams,
            full_scale: Some(250.0),
        }),
        flags: vec!["inconsistent".into()],
        tare: TareState::Resting,
    }
}

/// A whole response to `GET path` (status line, then headers and body as text).
fn get(addr: SocketAddr, path: &str) -> (String, String) {
    let mut s = TcpStream::connect(addr).unwrap();
    s.set_read_timeout(Some(Duration::from_secs(5))).unwrap();
    write!(s, "GET {path} HTTP/1.1\r\nHost: t\r\n\r\n").unwrap();
    let mut all = String::new();
    s.read_to_string(&mut all).unwrap();
    let (status, rest) = all.split_once("\r\n").unwrap();
    (status.to_owned(), rest.to_owned())
}

/// An event-stream client: reads until it has `n` events, returns their data.
struct Sse {
    stream: TcpStream,
    text: String,
}

impl Sse {
    fn connect(addr: SocketAddr) -> Sse {
        let mut stream = TcpStream::connect(addr).unwrap();
        stream
            .set_read_timeout(Some(Duration::from_secs(5)))
            .unwrap();
        stream
            .write_all(b"GET /events HTTP/1.1\r\nHost: t\r\n\r\n")
            .unwrap();
        Sse {
            stream,
            text: String::new(),
        }
    }

    fn events(&mut self, n: usize) -> Vec<serde_json::Value> {
        let mut buf = [0u8; 65536];
        loop {
            let data: Vec<_> = self
                .text
                .split("\n\n")
                .filter_map(|e| e.strip_prefix("data: "))
                .map(|d| serde_json::from_str(d).unwrap())
                .collect();
            if data.len() >= n && self.text.ends_with("\n\n") {
                return data;
            }
            let k = self.stream.read(&mut buf).expect("an event within 5 s");
            assert!(k > 0, "stream closed after {:?}", self.text);
            self.text.push_str(std::str::from_utf8(&buf[..k]).unwrap());
        }
    }
}

fn wait_until(what: &str, mut cond: impl FnMut() -> bool) {
    let t0 = Instant::now();
    while !cond() {
        assert!(
            t0.elapsed() < Duration::from_secs(5),
            "timed out waiting for {what}"
        );
        std::thread::sleep(Duration::from_millis(5));
    }
}

#[test]
fn frame_json_is_what_the_page_reads() {
    let v: serde_json::Value =
        serde_json::from_str(&array_frame(100.0, 1).to_json().unwrap()).unwrap();
    assert_eq!(v["kind"], "array");
    assert_eq!(v["frame_time_s"], 2.5);
    assert_eq!(v["array"]["labels"][1], "B");
    assert_eq!(v["array"]["loads"][1], 100.0);
    assert_eq!(v["array"]["unit"], "g");
    assert_eq!(v["tare"]["state"], "resting");
    assert_eq!(v["flags"][0], "inconsistent");

    let module = FrameView {
        design_name: "clip-on-10mm".into(),
        frame_time_ns: 0,
        reading: ReadingView::Module(ModuleView {
            core_labels: vec!["psc1".into(), "psc2".into()],
            core_forces_n: vec![Some(5.0), None],
        }),
        flags: vec![],
        tare: TareState::Refused {
            moving_gratings: vec!["lambda_11".into()],
        },
    };
    let v: serde_json::Value = serde_json::from_str(&module.to_json().unwrap()).unwrap();
    assert_eq!(v["module"]["forces_n"], serde_json::json!([5.0, null]));
    assert_eq!(v["tare"]["text"], "refused: moving gratings lambda_11");
    assert_eq!(v["tare"]["moving_gratings"][0], "lambda_11");

    let mut bad = array_frame(1.0, 1);
    if let ReadingView::Array(a) = &mut bad.reading {
        a.cell_loads.pop();
    }
    assert!(matches!(
        bad.to_json(),
        Err(PublishError::LengthMismatch {
            what: "cell_loads",
            ..
        })
    ));
}

#[test]
fn the_page_is_self_contained_and_a_label_cannot_close_its_script() {
    let page = page_html(None);
    for pattern in [
        "src=",
        "href=",
        "<link",
        "@import",
        "url(",
        "<iframe",
        "<img",
        "fetch(",
        "XMLHttpRequest",
        "WebSocket",
    ] {
        assert!(!page.contains(pattern), "the page has {pattern}");
    }
    // The only "://" is the SVG namespace name, which is never fetched.
    assert_eq!(page.matches("://").count(), 1);
    assert!(page.contains("\"http://www.w3.org/2000/svg\""));
    assert!(page.contains("new EventSource(\"/events\")"));
    let mut evil = array_frame(1.0, 1);
    evil.design_name = "</script><script>alert(1)</script>".into();
    let page = page_html(Some(&evil.to_json().unwrap()));
    assert_eq!(
        page.matches("</script>").count(),
        2,
        "the two script elements only"
    );
    assert!(page.contains("\\u003c/script>"));
}

#[test]
fn pages_and_events_are_served_to_several_clients() {
    let view = serve("127.0.0.1:0").unwrap();
    let addr = view.local_addr();
    let (status, _) = get(addr, "/frame.json");
    assert_eq!(status, "HTTP/1.1 204 No Content");
    view.push(&array_frame(100.0, 1)).unwrap();

    let (status, rest) = get(addr, "/");
    assert_eq!(status, "HTTP/1.1 200 OK");
    assert!(rest.contains("Content-Type: text/html; charset=utf-8"));
    assert!(rest.contains("Content-Security-Policy: default-src 'none'"));
    assert!(
        rest.contains(r#""loads":[0.0,100.0,0.0"#),
        "the latest frame is in the page"
    );
    let (status, body) = get(addr, "/frame.json");
    assert_eq!(status, "HTTP/1.1 200 OK");
    assert!(body.ends_with(&array_frame(100.0, 1).to_json().unwrap()));
    assert_eq!(get(addr, "/nothing").0, "HTTP/1.1 404 Not Found");

    let mut a = Sse::connect(addr);
    let mut b = Sse::connect(addr);
    assert_eq!(
        a.events(1)[0]["array"]["loads"][1],
        100.0,
        "the latest frame on connect"
    );
    assert_eq!(b.events(1)[0]["array"]["loads"][1], 100.0);
    assert!(a
        .text
        .starts_with("HTTP/1.1 200 OK\r\nContent-Type: text/event-stream"));
    assert_eq!(view.stats().clients_connected, 2);
    view.push(&array_frame(120.0, 1)).unwrap();
    assert_eq!(a.events(2)[1]["array"]["loads"][1], 120.0);
    assert_eq!(b.events(2)[1]["array"]["loads"][1], 120.0);

    // A client that leaves is noticed (by its writer or by the next push) and counted.
    drop(a);
    wait_until("the closed client to be counted", || {
        let _ = view.push(&array_frame(130.0, 1));
        view.stats().clients_disconnected == 1
    });
    assert_eq!(view.stats().clients_connected, 1);
    assert_eq!(b.events(3)[2]["array"]["loads"][1], 130.0);
    let stats = view.stats();
    assert_eq!((stats.pages_served, stats.clients_dropped_slow), (1, 0));
}

#[test]
fn a_stalled_client_is_dropped_and_never_blocks_push() {
    let options = WebOptions {
        client_queue_frames: 4,
        ..WebOptions::default()
    };
    let view = serve_with("127.0.0.1:0", options).unwrap();
    let addr = view.local_addr();
    let mut reader = Sse::connect(addr);
    reader.events(0);
    // A client that reads everything, in its own thread.
    let mut reading = reader.stream.try_clone().unwrap();
    let drain = std::thread::spawn(move || {
        let mut buf = vec![0u8; 1 << 16];
        let mut total = 0usize;
        while let Ok(n) = reading.read(&mut buf) {
            if n == 0 {
                break;
            }
            total += n;
        }
        total
    });
    // Connects and never reads: its socket buffers fill, then its queue.
    let stalled = Sse::connect(addr);
    wait_until("two clients", || view.stats().clients_connected == 2);
    // Frames of about 1 MB: a few dozen fill any loopback buffers.
    let big = array_frame(100.0, 1 << 20);
    let mut slowest = Duration::ZERO;
    for _ in 0..200 {
        let t = Instant::now();
        view.push(&big).unwrap();
        slowest = slowest.max(t.elapsed());
        if view.stats().clients_dropped_slow == 1 {
            break;
        }
        std::thread::sleep(Duration::from_millis(2));
    }
    let stats = view.stats();
    assert_eq!(stats.clients_dropped_slow, 1, "{stats:?}");
    assert_eq!(stats.clients_connected, 1, "the reading client stays");
    assert!(
        slowest < Duration::from_millis(200),
        "push took {slowest:?}"
    );
    drop(view);
    assert!(
        drain.join().unwrap() > 1 << 20,
        "the reading client got the frames"
    );
    drop(stalled);
}

#[test]
fn too_many_viewers_get_503_and_drop_stops_everything_at_once() {
    let options = WebOptions {
        max_clients: 1,
        ..WebOptions::default()
    };
    let view = serve_with("127.0.0.1:0", options).unwrap();
    let addr = view.local_addr();
    view.push(&array_frame(1.0, 1)).unwrap();
    let mut first = Sse::connect(addr);
    first.events(1);
    assert_eq!(get(addr, "/events").0, "HTTP/1.1 503 Service Unavailable");
    assert_eq!(view.stats().clients_refused, 1);
    // A connection that never sends its request.
    let idle = TcpStream::connect(addr).unwrap();
    std::thread::sleep(Duration::from_millis(50));

    let t = Instant::now();
    drop(view);
    assert!(
        t.elapsed() < Duration::from_secs(1),
        "drop took {:?}",
        t.elapsed()
    );
    // The event stream ends and the port is closed.
    let mut rest = Vec::new();
    let _ = first.stream.read_to_end(&mut rest);
    assert!(TcpStream::connect(addr).is_err());
    drop(idle);
}

#[test]
fn a_new_page_gets_a_modules_last_10_s_and_an_arrays_latest_frame() {
    let view = serve("127.0.0.1:0").unwrap();
    let at = |s: u64| FrameView {
        design_name: "clip-on-10mm".into(),
        frame_time_ns: s * 1_000_000_000,
        reading: ReadingView::Module(ModuleView {
            core_labels: vec!["psc1".into()],
            core_forces_n: vec![Some(s as f64)],
        }),
        flags: vec![],
        tare: TareState::Resting,
    };
    for s in 0..=15 {
        view.push(&at(s)).unwrap();
    }
    let mut c = Sse::connect(view.local_addr());
    let forces: Vec<f64> = c
        .events(11)
        .iter()
        .map(|e| e["module"]["forces_n"][0].as_f64().unwrap())
        .collect();
    assert_eq!(forces, (5..=15).map(|s| s as f64).collect::<Vec<_>>());
    // The stream's clock went back (a restarted instrument): the history restarts.
    view.push(&at(3)).unwrap();
    let mut d = Sse::connect(view.local_addr());
    let first = d.events(1);
    assert_eq!(first[0]["module"]["forces_n"][0], 3.0);
    std::thread::sleep(Duration::from_millis(100));
    d.stream
        .set_read_timeout(Some(Duration::from_millis(100)))
        .unwrap();
    let mut more = [0u8; 256];
    assert!(d.stream.read(&mut more).is_err(), "only the one frame");

    // An array: the latest frame only.
    for s in 20..25 {
        view.push(&array_frame(s as f64, 1)).unwrap();
    }
    let mut e = Sse::connect(view.local_addr());
    assert_eq!(e.events(1)[0]["array"]["loads"][1], 24.0);
    e.stream
        .set_read_timeout(Some(Duration::from_millis(100)))
        .unwrap();
    assert!(e.stream.read(&mut more).is_err(), "only the latest frame");
}
