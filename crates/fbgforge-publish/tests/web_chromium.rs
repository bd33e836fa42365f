//! The browser view in a real browser: `serve` on loopback, scripted frames pushed,
//! then headless Chromium loads the page and the DOM must show the pushed state.
//!
//! * `--dump-dom` (the page as loaded: it draws the latest frame, which the server puts
//!   in the page, before its `load` event). Without `--virtual-time-budget`: virtual
//!   time does not advance while a fetch is pending, and the event stream never ends,
//!   so with a budget Chromium (156) never dumps at all.
//! * Chrome DevTools Protocol over `--remote-debugging-pipe` (no extra crate: the pipe
//!   is the child's fds 3 and 4, mapped by `sh`): the page is followed live — it must
//!   draw the frame the event stream opens with, then a frame pushed while it watches.
//!
//! Chromium: `$CHROMIUM`, else `/usr/bin/chromium` or `chromium` on the PATH. Under
//! `CI=true` a missing browser fails the test; elsewhere it is skipped with a note.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use fbgforge_publish::web::{serve, ArrayView, FrameView, LoadUnit, ModuleView, ReadingView};
use fbgforge_publish::TareState;
use serde_json::{json, Value};

fn chromium() -> Option<PathBuf> {
    if let Some(p) = std::env::var_os("CHROMIUM").filter(|p| !p.is_empty()) {
        return Some(PathBuf::from(p));
    }
    let mut candidates = vec![PathBuf::from("/usr/bin/chromium")];
    if let Some(path) = std::env::var_os("PATH") {
        candidates.extend(std::env::split_paths(&path).map(|d| d.join("chromium")));
    }
    candidates.into_iter().find(|p| p.is_file())
}

fn chromium_or_skip(test: &str) -> Option<PathBuf> {
    let found = chromium();
    if found.is_none() {
        let ci = std::env::var("CI").is_ok_and(|v| !v.is_empty() && v != "false");
        assert!(
            !ci,
            "{test}: no chromium, but CI must run the browser test (apt-get install chromium)"
        );
        eprintln!("\n*** {test}: SKIPPED: no chromium on this machine (apt-get install chromium, or set CHROMIUM) ***\n");
    }
    found
}

/// The flags of every run: headless, no sandbox (root), no GPU, no network of its own.
const FLAGS: [&str; 8] = [
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
];

/// `chromium --headless … --dump-dom URL`: the DOM once the page has loaded.
fn dump_dom(browser: &Path, url: &str) -> String {
    let profile = tempfile::tempdir().unwrap();
    let out = tempfile::NamedTempFile::new().unwrap();
    let err = tempfile::NamedTempFile::new().unwrap();
    let mut child = Command::new(browser)
        .args(FLAGS)
        .arg(format!("--user-data-dir={}", profile.path().display()))
        .arg("--dump-dom")
        .arg(url)
        .stdin(Stdio::null())
        .stdout(out.reopen().unwrap())
        .stderr(err.reopen().unwrap())
        .spawn()
        .expect("chromium starts");
    let t0 = Instant::now();
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s;
        }
        if t0.elapsed() > Duration::from_secs(120) {
            let _ = child.kill();
            let _ = child.wait();
            panic!(
                "chromium: no DOM within 120 s: {}",
                std::fs::read_to_string(err.path()).unwrap_or_default()
            );
        }
        std::thread::sleep(Duration::from_millis(50));
    };
    assert!(
        status.success(),
        "chromium: {status}: {}",
        std::fs::read_to_string(err.path()).unwrap_or_default()
    );
    std::fs::read_to_string(out.path()).unwrap()
}

/// The value of attribute `name` in one element's start tag.
fn attr<'a>(el: &'a str, name: &str) -> Option<&'a str> {
    let key = format!(" {name}=\"");
    let start = el.find(&key)? + key.len();
    let len = el[start..].find('"')?;
    Some(&el[start..start + len])
}

/// The start tags of the elements that have attribute `name`.
fn tags_with<'a>(dom: &'a str, name: &str) -> Vec<&'a str> {
    dom.split('<')
        .filter_map(|t| t.split('>').next())
        .filter(|t| t.contains(&format!(" {name}=\"")))
        .collect()
}

fn array_frame(time_s: u64, load_b_g: f64, tare: TareState) -> FrameView {
    let labels = ["A", "B", "C", "D", "E", "F", "G", "H"];
    let mut loads = vec![0.0; 8];
    loads[1] = load_b_g;
    loads[6] = 3.0; // a little noise elsewhere
    FrameView {
        design_name: "tactile-array-60x80".into(),
        frame_time_ns: time_s * 1_000_000_000,
        reading: ReadingView::Array(ArrayView {
            nx: 4,
            ny: 2,
            cell_labels: labels.iter().map(|s| s.to_string()).collect(),
            cell_loads: loads,
            load_unit: LoadUnit::Grams,
            full_scale: Some(250.0),
        }),
        flags: vec!["inconsistent".into()],
        tare,
    }
}

#[test]
fn the_heat_map_shows_100_g_on_b_and_the_tare_state() {
    let Some(browser) = chromium_or_skip("the_heat_map_shows_100_g_on_b_and_the_tare_state") else {
        return;
    };
    let view = serve("127.0.0.1:0").unwrap();
    view.push(&array_frame(1, 0.0, TareState::Waiting)).unwrap();
    view.push(&array_frame(2, 100.0, TareState::Resting))
        .unwrap();
    let dom = dump_dom(&browser, &view.url());

    let cells = tags_with(&dom, "data-cell");
    assert_eq!(cells.len(), 8, "eight cells in the DOM:\n{dom}");
    let loads: Vec<(&str, f64)> = cells
        .iter()
        .map(|c| {
            (
                attr(c, "data-cell").unwrap(),
                attr(c, "data-load").unwrap().parse().unwrap(),
            )
        })
        .collect();
    let (top, load) = loads
        .iter()
        .copied()
        .fold(("", f64::MIN), |a, b| if b.1 > a.1 { b } else { a });
    assert_eq!(top, "B", "{loads:?}");
    assert!((load - 100.0).abs() < 1e-9, "{loads:?}");
    assert!(dom.contains(">100 g<"), "the value is printed in the cell");
    // Drawn +y up: the top row (E–H) comes first.
    assert_eq!(loads.iter().map(|l| l.0).collect::<String>(), "EFGHABCD");

    let tare = tags_with(&dom, "data-tare");
    assert_eq!(tare.len(), 1);
    assert_eq!(attr(tare[0], "data-tare"), Some("resting"));
    assert!(dom.contains("tare: resting"));
    assert_eq!(
        tags_with(&dom, "data-flag")
            .iter()
            .map(|t| attr(t, "data-flag").unwrap())
            .collect::<Vec<_>>(),
        ["inconsistent"]
    );
    let root = tags_with(&dom, "data-source");
    assert_eq!(attr(root[0], "data-kind"), Some("array"));
    // Drawn from the copy of the latest frame the page carries, or already from the
    // event stream, which opens with the same frame (the live test below follows it).
    let source = attr(root[0], "data-source").unwrap();
    assert!(source == "page" || source == "events", "{}", root[0]);
    assert!(view.stats().pages_served >= 1);
}

#[test]
fn the_module_view_shows_force_traces_and_a_refused_tare() {
    let Some(browser) = chromium_or_skip("the_module_view_shows_force_traces_and_a_refused_tare")
    else {
        return;
    };
    let view = serve("127.0.0.1:0").unwrap();
    let refused = TareState::Refused {
        moving_gratings: vec!["lambda_11".into(), "lambda_12".into()],
    };
    view.push(&FrameView {
        design_name: "clip-on-10mm".into(),
        frame_time_ns: 5_000_000_000,
        reading: ReadingView::Module(ModuleView {
            core_labels: vec!["psc1".into(), "psc2".into()],
            core_forces_n: vec![Some(5.0), None],
        }),
        flags: vec![],
        tare: refused,
    })
    .unwrap();
    let dom = dump_dom(&browser, &view.url());
    let legend = tags_with(&dom, "data-force");
    assert_eq!(legend.len(), 2, "{dom}");
    assert_eq!(attr(legend[0], "data-core"), Some("psc1"));
    assert_eq!(attr(legend[0], "data-force"), Some("5"));
    assert_eq!(attr(legend[1], "data-force"), Some(""), "a missing force");
    assert_eq!(dom.matches("<polyline").count(), 2, "one trace per core");
    assert!(dom.contains("tare: refused: moving gratings lambda_11, lambda_12"));
    assert_eq!(
        attr(tags_with(&dom, "data-tare")[0], "data-tare"),
        Some("refused")
    );
    assert!(dom.contains(">trusted<"), "no flags");
}

/// Headless Chromium driven over the DevTools protocol on a pipe: messages are JSON,
/// each ended by a NUL byte, written to the browser's fd 3 and read from its fd 4.
struct Cdp {
    child: std::process::Child,
    to_browser: std::process::ChildStdin,
    from_browser: std::process::ChildStdout,
    buf: Vec<u8>,
    next_id: u64,
    _profile: tempfile::TempDir,
}

impl Cdp {
    fn start(browser: &Path) -> Cdp {
        let profile = tempfile::tempdir().unwrap();
        // `sh` maps its stdin and stdout to the browser's fds 3 and 4, then gets out
        // of the way (`exec`).
        let mut child = Command::new("sh")
            .arg("-c")
            .arg(r#"exec "$0" "$@" 3<&0 4>&1 0</dev/null 1>/dev/null"#)
            .arg(browser)
            .args(FLAGS)
            .arg(format!("--user-data-dir={}", profile.path().display()))
            .arg("--remote-debugging-pipe")
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn()
            .expect("chromium starts");
        Cdp {
            to_browser: child.stdin.take().unwrap(),
            from_browser: child.stdout.take().unwrap(),
            child,
            buf: Vec::new(),
            next_id: 1,
            _profile: profile,
        }
    }

    /// Sends a command and returns its answer (events in between are skipped).
    fn call(&mut self, session: Option<&str>, method: &str, params: Value) -> Value {
        use std::io::{Read, Write};
        let id = self.next_id;
        self.next_id += 1;
        let mut msg = json!({"id": id, "method": method, "params": params});
        if let Some(s) = session {
            msg["sessionId"] = json!(s);
        }
        let mut bytes = msg.to_string().into_bytes();
        bytes.push(0);
        self.to_browser.write_all(&bytes).unwrap();
        loop {
            while let Some(end) = self.buf.iter().position(|&b| b == 0) {
                let reply: Value = serde_json::from_slice(&self.buf[..end]).unwrap();
                self.buf.drain(..=end);
                if reply["id"] == id {
                    return reply;
                }
            }
            let mut chunk = [0u8; 65536];
            let n = self.from_browser.read(&mut chunk).unwrap();
            assert!(n > 0, "chromium closed the DevTools pipe during {method}");
            self.buf.extend_from_slice(&chunk[..n]);
        }
    }

    /// Opens `url` in a new page; returns the page's session.
    fn open(&mut self, url: &str) -> String {
        let target = self.call(None, "Target.createTarget", json!({"url": url}));
        let target_id = target["result"]["targetId"]
            .as_str()
            .expect("a target")
            .to_owned();
        let attached = self.call(
            None,
            "Target.attachToTarget",
            json!({"targetId": target_id, "flatten": true}),
        );
        attached["result"]["sessionId"]
            .as_str()
            .expect("a session")
            .to_owned()
    }

    /// Waits (up to 10 s) until the JavaScript condition `cond` holds in the page, then
    /// returns the page's HTML. Retries while the page is still navigating.
    fn html_when(&mut self, session: &str, cond: &str) -> String {
        let expr = format!(
            "new Promise((done) => {{ const t0 = Date.now(); (function poll() {{ \
               let ok = false; try {{ ok = ({cond}); }} catch (e) {{}} \
               if (ok) done(document.documentElement.outerHTML); \
               else if (Date.now() - t0 > 10000) done('TIMEOUT ' + document.documentElement.outerHTML); \
               else setTimeout(poll, 20); }})(); }})"
        );
        let t0 = Instant::now();
        loop {
            let r = self.call(
                Some(session),
                "Runtime.evaluate",
                json!({"expression": expr, "awaitPromise": true, "returnByValue": true}),
            );
            if let Some(html) = r["result"]["result"]["value"].as_str() {
                assert!(
                    !html.starts_with("TIMEOUT"),
                    "the page never showed `{cond}`:\n{html}"
                );
                return html.to_owned();
            }
            // "Execution context was destroyed": the page navigated under the call.
            assert!(
                t0.elapsed() < Duration::from_secs(30),
                "no answer to `{cond}`: {r}"
            );
            std::thread::sleep(Duration::from_millis(50));
        }
    }

    fn close(mut self) {
        let _ = self.call(None, "Browser.close", json!({}));
        let t0 = Instant::now();
        while self.child.try_wait().unwrap().is_none() {
            if t0.elapsed() > Duration::from_secs(10) {
                let _ = self.child.kill();
                break;
            }
            std::thread::sleep(Duration::from_millis(20));
        }
        let _ = self.child.wait();
    }
}

fn loads_by_cell(html: &str) -> Vec<(String, f64)> {
    tags_with(html, "data-cell")
        .iter()
        .map(|c| {
            (
                attr(c, "data-cell").unwrap().to_owned(),
                attr(c, "data-load").unwrap().parse().unwrap(),
            )
        })
        .collect()
}

#[test]
fn the_page_follows_the_event_stream() {
    let Some(browser) = chromium_or_skip("the_page_follows_the_event_stream") else {
        return;
    };
    let view = serve("127.0.0.1:0").unwrap();
    view.push(&array_frame(1, 100.0, TareState::Waiting))
        .unwrap();
    let mut cdp = Cdp::start(&browser);
    let page = cdp.open(&view.url());
    // The stream opens with the latest frame: drawn from it, B carries 100 g.
    let html = cdp.html_when(
        &page,
        "document.getElementById('root').dataset.source === 'events'",
    );
    let loads = loads_by_cell(&html);
    assert!(loads.contains(&("B".to_owned(), 100.0)), "{loads:?}");
    assert_eq!(view.stats().clients_connected, 1);

    // A frame pushed while the page watches: 150 g moves to C, the tare is refused.
    let mut next = array_frame(
        2,
        0.0,
        TareState::Refused {
            moving_gratings: vec!["g3".into()],
        },
    );
    if let ReadingView::Array(a) = &mut next.reading {
        a.cell_loads[2] = 150.0;
    }
    next.flags.clear();
    view.push(&next).unwrap();
    let html = cdp.html_when(
        &page,
        "document.querySelector('[data-cell=\"C\"]').dataset.load === '150'",
    );
    let loads = loads_by_cell(&html);
    let top = loads.iter().max_by(|a, b| a.1.total_cmp(&b.1)).unwrap();
    assert_eq!((top.0.as_str(), top.1), ("C", 150.0), "{loads:?}");
    assert!(loads.contains(&("B".to_owned(), 0.0)));
    assert_eq!(
        attr(tags_with(&html, "data-tare")[0], "data-tare"),
        Some("refused")
    );
    assert!(html.contains("tare: refused: moving gratings g3"));
    assert!(html.contains(">trusted<"));
    assert!(
        html.contains("id=\"conn\" data-conn=\"live\""),
        "the page says it is live"
    );
    cdp.close();
    // The closed page is noticed and counted (by its writer, or at the next push).
    let t0 = Instant::now();
    while view.stats().clients_disconnected == 0 {
        assert!(t0.elapsed() < Duration::from_secs(10), "{:?}", view.stats());
        let _ = view.push(&next);
        std::thread::sleep(Duration::from_millis(20));
    }
    assert_eq!(view.stats().clients_connected, 0);
}
