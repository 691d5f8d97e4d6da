//! A progress bar on stderr, shared by the sweep's worker threads: runs done of the total, what
//! is running, elapsed time and an estimate of the rest. On a terminal one line is redrawn; to a
//! file or pipe each finished run prints one line.

use std::io::{IsTerminal, Write};
use std::sync::Mutex;
use std::time::{Duration, Instant};

pub struct Progress {
    enabled: bool,
    terminal: bool,
    total: usize,
    start: Instant,
    state: Mutex<State>,
}

#[derive(Default)]
struct State {
    done: usize,
    /// Of `done`, how many took no time (cached): left out of the estimate.
    skipped: usize,
    running: Vec<String>,
    status: String,
    last_draw: Option<Instant>,
}

fn clock(d: Duration) -> String {
    let s = d.as_secs();
    if s >= 3600 {
        format!("{}h{:02}m{:02}s", s / 3600, s / 60 % 60, s % 60)
    } else {
        format!("{}m{:02}s", s / 60, s % 60)
    }
}

impl Progress {
    /// A bar for `total` runs.
    pub fn new(total: usize) -> Self {
        Progress {
            enabled: true,
            terminal: std::io::stderr().is_terminal(),
            total,
            start: Instant::now(),
            state: Mutex::default(),
        }
    }

    /// Prints nothing.
    pub fn hidden() -> Self {
        Progress { enabled: false, ..Progress::new(0) }
    }

    /// What the sweep does between runs (loading a scene).
    pub fn status(&self, text: &str) {
        let mut st = self.lock();
        st.status = text.to_owned();
        self.draw(&mut st, true);
    }

    pub fn started(&self, label: &str) {
        let mut st = self.lock();
        st.status.clear();
        st.running.push(label.to_owned());
        self.draw(&mut st, true);
    }

    pub fn done(&self, label: &str) {
        let mut st = self.lock();
        st.done += 1;
        st.running.retain(|r| r != label);
        if self.enabled && !self.terminal {
            eprintln!("[{}/{}] {} done, {} elapsed", st.done, self.total, label, clock(self.start.elapsed()));
        }
        self.draw(&mut st, true);
    }

    /// A run that needed no simulation (its result was cached, or known): counted as done, but
    /// not in the rate the estimate of the rest assumes.
    pub fn skipped(&self, label: &str) {
        self.lock().skipped += 1;
        self.done(label);
    }

    /// Redraws now and then, so elapsed time moves during long runs.
    pub fn tick(&self) {
        let mut st = self.lock();
        self.draw(&mut st, false);
    }

    /// Ends the bar's line.
    pub fn finish(&self) {
        if self.enabled && self.terminal {
            eprintln!();
        }
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, State> {
        // A panicking worker cannot leave the counters half-updated: keep going.
        self.state.lock().unwrap_or_else(|e| e.into_inner())
    }

    fn draw(&self, st: &mut State, force: bool) {
        if !self.enabled || !self.terminal {
            return;
        }
        if !force && st.last_draw.is_some_and(|t| t.elapsed() < Duration::from_millis(250)) {
            return;
        }
        st.last_draw = Some(Instant::now());
        let elapsed = self.start.elapsed();
        let width = 24;
        let filled = (st.done * width).checked_div(self.total).unwrap_or(0).min(width);
        let eta = match st.done - st.skipped {
            0 => "?".to_string(),
            d => clock(elapsed.mul_f64(self.total.saturating_sub(st.done) as f64 / d as f64)),
        };
        let what = if st.status.is_empty() { st.running.join(", ") } else { st.status.clone() };
        let mut line = format!(
            "[{}{}] {}/{} runs, {} elapsed, ETA {} | {}",
            "#".repeat(filled),
            "-".repeat(width - filled),
            st.done,
            self.total,
            clock(elapsed),
            eta,
            what
        );
        if let Some((i, _)) = line.char_indices().nth(150) {
            line.truncate(i);
        }
        let mut err = std::io::stderr().lock();
        let _ = write!(err, "\r\x1b[K{line}");
        let _ = err.flush();
    }
}
