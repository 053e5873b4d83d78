//! Progress of a long phase, on standard error: a live bar when standard error is a terminal,
//! otherwise (a CI log, a file, a pipe) a plain line at most every [`PLAIN_INTERVAL`], and only
//! once a phase has run that long, so a short run prints none. Never a carriage return into a
//! log: issue 19 found `check`'s progress written with `\r` as one 2,000-character line.
//!
//! Lines a subcommand prints on standard output while a bar is drawn go through
//! [`Progress::println`], so that they do not tear the bar on a shared terminal.

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::io::{IsTerminal, Write};
use std::time::{Duration, Instant};

/// The shortest time between two plain progress lines, and before the first one, unless the
/// environment variable [`INTERVAL_VARIABLE`] gives another.
pub const PLAIN_INTERVAL: Duration = Duration::from_secs(5);

/// `PMACWD_PROGRESS_SECONDS`: the time between plain progress lines, in seconds (decimals
/// allowed, at least 0.1), for a CI log that wants more or fewer of them.
pub const INTERVAL_VARIABLE: &str = "PMACWD_PROGRESS_SECONDS";

static INTERVAL: std::sync::OnceLock<Duration> = std::sync::OnceLock::new();

/// Reads [`INTERVAL_VARIABLE`] once, before any work; a value that is not a number of seconds
/// of at least 0.1 is an error (unusable input), not silently the default.
pub fn configure() -> Result<(), String> {
    let interval = match std::env::var_os(INTERVAL_VARIABLE) {
        None => PLAIN_INTERVAL,
        Some(v) => {
            let text = v.to_string_lossy();
            match text.trim().parse::<f64>() {
                Ok(s) if (0.1..=86_400.0).contains(&s) => Duration::from_secs_f64(s),
                _ => {
                    return Err(format!(
                        "{INTERVAL_VARIABLE}={text}: give seconds between progress lines, 0.1 to 86400"
                    ))
                }
            }
        }
    };
    let _ = INTERVAL.set(interval);
    Ok(())
}

/// The start of every plain progress line (the golden tests drop these lines: when they come
/// depends on the machine's speed).
pub const PLAIN_PREFIX: &str = "progress: ";

/// One phase of work: `total` steps of some unit (runs, traces), each of which may report how
/// far it has come.
pub struct Progress {
    kind: Kind,
}

enum Kind {
    Bar(ProgressBar),
    Plain(Plain),
}

impl Progress {
    /// Starts phase `phase` (`model check`) of `total` `unit` (`runs`), drawn as standard error
    /// allows: a bar on a terminal, plain periodic lines otherwise.
    pub fn start(phase: &str, total: u64, unit: &str) -> Progress {
        if std::io::stderr().is_terminal() {
            let bar = ProgressBar::with_draw_target(Some(total), ProgressDrawTarget::stderr());
            let template = format!("{{prefix}} [{{bar:30}}] {{pos}}/{{len}} {unit} {{elapsed}} {{wide_msg}}");
            let style = ProgressStyle::with_template(&template)
                .expect("the template is a constant with known keys")
                .progress_chars("=> ");
            bar.set_style(style);
            bar.set_prefix(phase.to_string());
            bar.enable_steady_tick(Duration::from_millis(200));
            Progress { kind: Kind::Bar(bar) }
        } else {
            let every = *INTERVAL.get().unwrap_or(&PLAIN_INTERVAL);
            let plain = Plain::new(phase, total, unit, Box::new(std::io::stderr()), every, Instant::now());
            Progress { kind: Kind::Plain(plain) }
        }
    }

    /// `done` steps are finished; `doing` says what is under way (called only when it is shown).
    pub fn update(&mut self, done: u64, doing: impl FnOnce() -> String) {
        match &mut self.kind {
            Kind::Bar(bar) => {
                bar.set_position(done);
                bar.set_message(doing());
            }
            Kind::Plain(plain) => plain.update(done, doing, Instant::now()),
        }
    }

    /// Prints `text` (with its line breaks) on standard output without tearing the bar.
    pub fn print(&self, text: &str) {
        let write = || {
            let mut out = std::io::stdout().lock();
            let _ = out.write_all(text.as_bytes());
            let _ = out.flush();
        };
        match &self.kind {
            Kind::Bar(bar) => bar.suspend(write),
            Kind::Plain(_) => write(),
        }
    }

    /// [`Progress::print`] of one line.
    pub fn println(&self, line: &str) {
        self.print(&format!("{line}\n"));
    }

    /// Ends the phase: the bar is cleared (what it showed is in the output already).
    pub fn finish(self) {
        if let Kind::Bar(bar) = self.kind {
            bar.finish_and_clear();
        }
    }
}

/// A phase whose work gives no natural moment to report (one trace step of 16 million servo
/// cycles, a capture of millions of lines): a thread asks `doing` every
/// [`Ticker::POLL`] how far the work has come and shows it as [`Progress`] does, so that no
/// run is silently minutes long.
pub struct Ticker {
    progress: std::sync::Arc<std::sync::Mutex<Progress>>,
    stop: std::sync::Arc<std::sync::atomic::AtomicBool>,
    thread: Option<std::thread::JoinHandle<()>>,
}

impl Ticker {
    /// How often `doing` is asked.
    pub const POLL: Duration = Duration::from_millis(200);

    /// Starts phase `phase` of `total` `unit`; `doing` returns how many are done and what is
    /// under way. Without a thread (the system refuses one), there is no progress, and the
    /// work goes on.
    pub fn start(phase: &str, total: u64, unit: &str, doing: impl Fn() -> (u64, String) + Send + 'static) -> Ticker {
        use std::sync::{atomic::AtomicBool, atomic::Ordering, Arc, Mutex};
        let progress = Arc::new(Mutex::new(Progress::start(phase, total, unit)));
        let stop = Arc::new(AtomicBool::new(false));
        let (p, s) = (Arc::clone(&progress), Arc::clone(&stop));
        let thread = std::thread::Builder::new()
            .name("progress".into())
            .spawn(move || {
                while !s.load(Ordering::Relaxed) {
                    std::thread::sleep(Ticker::POLL);
                    let (done, what) = doing();
                    if let Ok(mut p) = p.lock() {
                        p.update(done, || what);
                    }
                }
            })
            .ok();
        Ticker { progress, stop, thread }
    }

    /// [`Progress::println`].
    pub fn println(&self, line: &str) {
        if let Ok(p) = self.progress.lock() {
            p.println(line);
        }
    }

    /// Ends the phase ([`Progress::finish`]).
    pub fn finish(mut self) {
        self.stop.store(true, std::sync::atomic::Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
        if let Ok(p) = std::sync::Arc::try_unwrap(self.progress) {
            if let Ok(p) = p.into_inner() {
                p.finish();
            }
        }
    }
}

/// Plain lines: `progress: model check: 12 of 25 runs done (10 s); timing / um-215: 57,536 states`.
struct Plain {
    phase: String,
    total: u64,
    unit: String,
    out: Box<dyn Write + Send>,
    every: Duration,
    started: Instant,
    /// When the last line was written (at first, the start: no line before `every` has passed).
    last: Instant,
}

impl Plain {
    fn new(phase: &str, total: u64, unit: &str, out: Box<dyn Write + Send>, every: Duration, now: Instant) -> Plain {
        Plain { phase: phase.to_string(), total, unit: unit.to_string(), out, every, started: now, last: now }
    }

    fn update(&mut self, done: u64, doing: impl FnOnce() -> String, now: Instant) {
        if now.duration_since(self.last) < self.every {
            return;
        }
        self.last = now;
        let doing = doing();
        let _ = writeln!(
            self.out,
            "{PLAIN_PREFIX}{}: {done} of {} {} done ({} s){}{doing}",
            self.phase,
            self.total,
            self.unit,
            now.duration_since(self.started).as_secs(),
            if doing.is_empty() { "" } else { "; " },
        );
        let _ = self.out.flush();
    }
}

/// `1234567` as `1,234,567` (the check report's own).
pub use pmacwd_conformance::check::thousands;

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::{Arc, Mutex};

    /// A writer whose bytes the test can read afterwards.
    #[derive(Clone, Default)]
    struct Shared(Arc<Mutex<Vec<u8>>>);

    impl Write for Shared {
        fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
            self.0.lock().unwrap().extend_from_slice(buf);
            Ok(buf.len())
        }
        fn flush(&mut self) -> std::io::Result<()> {
            Ok(())
        }
    }

    #[test]
    fn plain_progress_is_whole_lines_at_most_one_per_interval_and_none_for_a_short_phase() {
        // What a CI log gets: no carriage return, nothing before the interval has passed (a
        // phase shorter than that prints nothing), then at most one line per interval, each
        // saying the phase, how far it is and what is under way.
        let out = Shared::default();
        let t0 = Instant::now();
        let every = Duration::from_secs(5);
        let mut p = Plain::new("exhaustive lockstep", 25, "runs", Box::new(out.clone()), every, t0);
        let at = |s: u64| t0 + Duration::from_secs(s);
        p.update(1, || "timing / um-215: 10 pair states".into(), at(1));
        p.update(2, || unreachable!("not shown before the interval"), at(4));
        p.update(3, || "status / srm-57: 1,234 pair states".into(), at(5));
        p.update(4, || unreachable!("not shown within the interval"), at(9));
        p.update(5, String::new, at(11));
        let text = String::from_utf8(out.0.lock().unwrap().clone()).unwrap();
        assert_eq!(
            text,
            "progress: exhaustive lockstep: 3 of 25 runs done (5 s); status / srm-57: 1,234 pair states\n\
             progress: exhaustive lockstep: 5 of 25 runs done (11 s)\n"
        );
        assert!(!text.contains('\r'));
    }

    #[test]
    fn thousands_are_separated_by_commas() {
        assert_eq!(thousands(0), "0");
        assert_eq!(thousands(999), "999");
        assert_eq!(thousands(1000), "1,000");
        assert_eq!(thousands(24_036_472), "24,036,472");
    }
}
