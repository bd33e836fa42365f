//! Steering `fbgforge live` while it runs: the terminal's keys (`t` tare again, `q`
//! quit), a control input (`--control`: lines `tare`, `stop`), and a closed output
//! seen as an error rather than a kill. Each hands its requests to the run's
//! [`LiveControl`].

use anyhow::{Context, Result};
use fbgforge::live::control::LiveControl;
use std::io::{BufRead, BufReader, Read, Seek};
use std::path::Path;
use std::sync::Arc;
use std::time::Duration;

/// Writing to a closed pipe gives an error (the run ends with its summary) instead of
/// SIGPIPE's kill (`main` restores the default for the other commands).
pub fn ignore_sigpipe() {
    #[cfg(unix)]
    // SAFETY: sets a signal's disposition; no handler runs Rust code.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_IGN);
    }
}

/// The terminal's settings while keys are read one by one, restored when dropped.
pub struct Keys {
    #[cfg(unix)]
    saved: libc::termios,
}

impl Drop for Keys {
    fn drop(&mut self) {
        #[cfg(unix)]
        // SAFETY: restores the settings read from the same descriptor.
        unsafe {
            libc::tcsetattr(libc::STDIN_FILENO, libc::TCSANOW, &self.saved);
        }
    }
}

/// Read single keys from the terminal on standard input: `t` asks for a new tare, `q`
/// stops. `None` when standard input is no terminal. Ctrl-C still signals.
pub fn keys(control: &Arc<LiveControl>) -> Option<Keys> {
    #[cfg(unix)]
    {
        use std::io::IsTerminal;
        if !std::io::stdin().is_terminal() {
            return None;
        }
        // SAFETY: termios is plain data; tcgetattr fills it or fails.
        let mut t: libc::termios = unsafe { std::mem::zeroed() };
        if unsafe { libc::tcgetattr(libc::STDIN_FILENO, &mut t) } != 0 {
            return None;
        }
        let saved = t;
        t.c_lflag &= !(libc::ICANON | libc::ECHO);
        t.c_cc[libc::VMIN] = 1;
        t.c_cc[libc::VTIME] = 0;
        // SAFETY: sets the settings just read, changed.
        if unsafe { libc::tcsetattr(libc::STDIN_FILENO, libc::TCSANOW, &t) } != 0 {
            return None;
        }
        let c = control.clone();
        std::thread::Builder::new()
            .name("fbgforge-live-keys".into())
            .spawn(move || {
                let mut stdin = std::io::stdin();
                let mut b = [0u8; 1];
                while let Ok(1) = stdin.read(&mut b) {
                    match b[0] {
                        b't' | b'T' => c.request_tare("key"),
                        b'q' | b'Q' => c.stop_because("q pressed"),
                        _ => {}
                    }
                }
            })
            .ok()?;
        Some(Keys { saved })
    }
    #[cfg(not(unix))]
    {
        let _ = control;
        None
    }
}

/// Read control lines from `source` (`-`: standard input; a named pipe: each writer's
/// lines in turn; a file: the lines written to it after the run starts) on their own
/// thread. An error naming the file when it does not exist.
pub fn control_input(source: &str, control: &Arc<LiveControl>) -> Result<()> {
    let c = control.clone();
    if source == "-" {
        spawn(move || {
            let stdin = std::io::stdin();
            apply_lines(stdin.lock(), "standard input", &c);
        });
        return Ok(());
    }
    let path = Path::new(source).to_path_buf();
    let meta = std::fs::metadata(&path)
        .with_context(|| format!("--control {}: no such file or named pipe", path.display()))?;
    if is_fifo(&meta) {
        spawn(move || loop {
            // Opening blocks until a writer opens its end; its end of file is the
            // writer closing, and the next writer is waited for.
            let Ok(f) = std::fs::File::open(&path) else {
                return;
            };
            apply_lines(BufReader::new(f), &path.display().to_string(), &c);
            if c.stopped() {
                return;
            }
        });
    } else {
        let mut f = std::fs::File::open(&path)
            .with_context(|| format!("--control {}: cannot open", path.display()))?;
        f.seek(std::io::SeekFrom::End(0))?;
        spawn(move || follow_file(f, &path.display().to_string(), &c));
    }
    Ok(())
}

fn spawn(f: impl FnOnce() + Send + 'static) {
    let _ = std::thread::Builder::new()
        .name("fbgforge-live-control".into())
        .spawn(f);
}

#[cfg(unix)]
fn is_fifo(meta: &std::fs::Metadata) -> bool {
    use std::os::unix::fs::FileTypeExt;
    meta.file_type().is_fifo()
}

#[cfg(not(unix))]
fn is_fifo(_meta: &std::fs::Metadata) -> bool {
    false
}

/// Apply every line of `r` until its end; a bad line is said as a `control` event.
fn apply_lines(r: impl BufRead, name: &str, c: &LiveControl) {
    for (n, line) in r.lines().enumerate() {
        let Ok(line) = line else { return };
        if let Err(e) = c.apply_line(&line, "control") {
            c.note("control", &format!("{name} line {}: {e}", n + 1));
        }
    }
}

/// Apply the lines appended to a regular file, polling for more.
fn follow_file(mut f: std::fs::File, name: &str, c: &LiveControl) {
    let mut pending = String::new();
    let mut buf = [0u8; 4096];
    let mut n_line = 0;
    while !c.stopped() {
        match f.read(&mut buf) {
            Ok(0) | Err(_) => std::thread::sleep(Duration::from_millis(50)),
            Ok(n) => {
                pending.push_str(&String::from_utf8_lossy(&buf[..n]));
                while let Some(end) = pending.find('\n') {
                    let line: String = pending.drain(..=end).collect();
                    n_line += 1;
                    if let Err(e) = c.apply_line(&line, "control") {
                        c.note("control", &format!("{name} new line {n_line}: {e}"));
                    }
                }
            }
        }
    }
}
