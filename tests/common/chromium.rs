//! Headless Chromium for the HTML report tests: a report is opened as a browser opens
//! it, a screenshot is taken and the DOM is dumped.
//!
//! CI installs `chromium` (`.ci/run`) and must run these tests: there, a missing
//! browser is a failure. On a machine without one the tests say loudly that they
//! skipped the browser and check the HTML text only.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// The browser: `$CHROMIUM` if set, else the first of the usual names on the PATH.
pub fn find() -> Option<PathBuf> {
    if let Some(p) = std::env::var_os("CHROMIUM").filter(|p| !p.is_empty()) {
        return Some(PathBuf::from(p));
    }
    let path = std::env::var_os("PATH")?;
    for name in [
        "chromium",
        "chromium-browser",
        "google-chrome",
        "google-chrome-stable",
    ] {
        for dir in std::env::split_paths(&path) {
            let p = dir.join(name);
            if p.is_file() {
                return Some(p);
            }
        }
    }
    None
}

/// The browser, or `None` after a loud message when this machine has none; in CI
/// (`CI` set) a missing browser fails the test.
pub fn browser_or_skip(test: &str) -> Option<PathBuf> {
    match find() {
        Some(p) => Some(p),
        None => {
            let ci = std::env::var("CI").is_ok_and(|v| !v.is_empty() && v != "false");
            assert!(
                !ci,
                "{test}: no chromium binary, but CI must render the HTML reports (.ci/run installs chromium)"
            );
            eprintln!(
                "\n*** {test}: SKIPPED the browser check: no chromium binary on this machine (install chromium, or set CHROMIUM=/path/to/chrome); only the HTML text was checked ***\n"
            );
            None
        }
    }
}

/// What the browser made of a page.
pub struct Rendered {
    /// The DOM after loading, serialised (`--dump-dom`).
    pub dom: String,
    /// Screenshot size (width, height), px.
    pub size: (u32, u32),
    /// Screenshot pixels, RGBA.
    pub rgba: Vec<u8>,
}

impl Rendered {
    /// Share of the screenshot's pixels that differ from the white page by more than
    /// 24 in some channel.
    pub fn ink_share(&self) -> f64 {
        let n = self.rgba.len() / 4;
        let inked = self
            .rgba
            .chunks_exact(4)
            .filter(|p| p[..3].iter().any(|&c| c < 231))
            .count();
        inked as f64 / n.max(1) as f64
    }

    /// Pixels within `tol` per channel of the colour `#rrggbb`.
    pub fn count_color(&self, hex: &str, tol: u8) -> usize {
        let c = u32::from_str_radix(hex.trim_start_matches('#'), 16).expect("#rrggbb");
        let want = [(c >> 16) as u8, (c >> 8) as u8, c as u8];
        self.rgba
            .chunks_exact(4)
            .filter(|p| (0..3).all(|k| p[k].abs_diff(want[k]) <= tol))
            .count()
    }
}

/// The usual flags: headless, no sandbox (root), no GPU, no network of its own.
fn base(browser: &Path, profile: &Path) -> Command {
    let mut c = Command::new(browser);
    c.args([
        "--headless",
        "--no-sandbox",
        "--disable-gpu",
        "--disable-quic",
        "--no-first-run",
        "--disable-background-networking",
        "--disable-component-update",
        "--disable-sync",
        "--hide-scrollbars",
    ])
    .arg(format!("--user-data-dir={}", profile.display()))
    .stdin(Stdio::null());
    c
}

/// Run `c` to its end within `limit`, returning stdout; panics on a timeout or failure.
fn run(mut c: Command, limit: Duration, what: &str) -> Vec<u8> {
    let dir = tempfile::tempdir().unwrap();
    let out_path = dir.path().join("stdout");
    let err_path = dir.path().join("stderr");
    c.stdout(std::fs::File::create(&out_path).unwrap())
        .stderr(std::fs::File::create(&err_path).unwrap());
    let mut child = c
        .spawn()
        .unwrap_or_else(|e| panic!("{what}: cannot start: {e}"));
    let t0 = Instant::now();
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s;
        }
        if t0.elapsed() > limit {
            let _ = child.kill();
            let _ = child.wait();
            panic!(
                "{what}: no answer within {limit:?}: {}",
                std::fs::read_to_string(&err_path).unwrap_or_default()
            );
        }
        std::thread::sleep(Duration::from_millis(50));
    };
    assert!(
        status.success(),
        "{what}: {status}: {}",
        std::fs::read_to_string(&err_path).unwrap_or_default()
    );
    std::fs::read(&out_path).unwrap()
}

/// Open `page` in headless Chromium: screenshot at `width` × `height` and the DOM.
pub fn render(browser: &Path, page: &Path, width: u32, height: u32) -> Rendered {
    let url = format!(
        "file://{}",
        page.canonicalize().expect("the page exists").display()
    );
    let limit = Duration::from_secs(120);
    let profile = tempfile::tempdir().unwrap();
    let mut c = base(browser, profile.path());
    c.arg("--dump-dom").arg(&url);
    let dom = String::from_utf8(run(c, limit, "chromium --dump-dom")).expect("UTF-8 DOM");

    let shots = tempfile::tempdir().unwrap();
    let png_path = shots.path().join("page.png");
    let profile = tempfile::tempdir().unwrap();
    let mut c = base(browser, profile.path());
    c.arg(format!("--screenshot={}", png_path.display()))
        .arg(format!("--window-size={width},{height}"))
        .arg(&url);
    run(c, limit, "chromium --screenshot");
    let file = std::fs::File::open(&png_path).expect("chromium wrote the screenshot");
    let mut decoder = png::Decoder::new(std::io::BufReader::new(file));
    decoder.set_transformations(png::Transformations::EXPAND | png::Transformations::ALPHA);
    let mut reader = decoder.read_info().expect("a PNG");
    let mut buf = vec![0; reader.output_buffer_size().expect("a PNG size")];
    let info = reader.next_frame(&mut buf).expect("PNG pixels");
    buf.truncate(info.buffer_size());
    let rgba = match info.color_type {
        png::ColorType::Rgba => buf,
        png::ColorType::Rgb => buf
            .chunks_exact(3)
            .flat_map(|p| [p[0], p[1], p[2], 255])
            .collect(),
        other => panic!("unexpected screenshot colour type {other:?}"),
    };
    Rendered {
        dom,
        size: (info.width, info.height),
        rgba,
    }
}

/// The ways a page could reach the network; a self-contained report has none.
pub fn external_references(html: &str) -> Vec<&'static str> {
    [
        "http://", "https://", "ftp://", "src=", "<script", "<link", "<iframe", "<img", "url(",
        "@import",
    ]
    .into_iter()
    .filter(|p| html.contains(p))
    .collect()
}

/// The value of attribute `name` in one element's text.
pub fn attr<'a>(el: &'a str, name: &str) -> Option<&'a str> {
    let key = format!(" {name}=\"");
    let start = el.find(&key)? + key.len();
    let len = el[start..].find('"')?;
    Some(&el[start..start + len])
}

/// Every element (its opening tag's text) whose tag starts with `open`
/// (e.g. `<polyline class="line"`).
pub fn elements<'a>(svg: &'a str, open: &str) -> Vec<&'a str> {
    let mut out = Vec::new();
    let mut rest = svg;
    while let Some(i) = rest.find(open) {
        let tail = &rest[i..];
        let end = tail.find('>').map_or(tail.len(), |e| e + 1);
        out.push(&tail[..end]);
        rest = &tail[end..];
    }
    out
}

/// A rectangle's (x, y, width, height) from its attributes.
pub fn rect(el: &str) -> (f64, f64, f64, f64) {
    let f = |n: &str| -> f64 {
        attr(el, n)
            .unwrap_or_else(|| panic!("no {n} in {el}"))
            .parse()
            .unwrap()
    };
    (f("x"), f("y"), f("width"), f("height"))
}

/// Points of a `points="x,y x,y"` attribute.
pub fn points(el: &str) -> Vec<(f64, f64)> {
    attr(el, "points")
        .unwrap_or_else(|| panic!("no points in {el}"))
        .split(' ')
        .map(|p| {
            let (a, b) = p.split_once(',').unwrap();
            (a.parse().unwrap(), b.parse().unwrap())
        })
        .collect()
}

/// The map from a chart's pixels back to data, read from its plot area's attributes
/// (linear axes).
pub fn pixel_to_data(svg: &str) -> impl Fn((f64, f64)) -> (f64, f64) {
    let area = elements(svg, r#"<rect class="plot-area""#)
        .into_iter()
        .next()
        .expect("a plot area");
    assert_eq!(attr(area, "data-x-scale"), Some("linear"));
    assert_eq!(attr(area, "data-y-scale"), Some("linear"));
    let (x, y, w, h) = rect(area);
    let g = |n: &str| -> f64 { attr(area, n).unwrap().parse().unwrap() };
    let (x0, x1, y0, y1) = (
        g("data-x-lo"),
        g("data-x-hi"),
        g("data-y-lo"),
        g("data-y-hi"),
    );
    move |(u, v)| {
        (
            x0 + (u - x) / w * (x1 - x0),
            y0 + (y + h - v) / h * (y1 - y0),
        )
    }
}
