//! The harness: run `pmacwd replay` on every generated log of a directory, with a timeout per
//! log, and count its verdicts against the sidecars.

use std::collections::BTreeMap;
use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::{Duration, Instant};

use crate::sidecar::Sidecar;

/// What `pmacwd replay` said about one log.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Verdict {
    /// Exit 0.
    Explained,
    /// Exit 1, with the line where the combination of readings that lasted longest failed.
    Impossible {
        line: Option<usize>,
    },
    /// Exit 2: undecided or unusable.
    Undecided,
    Timeout,
    /// The command could not run, or exited with another code.
    Failed(String),
}

/// How a verdict compares with the sidecar.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Category {
    CorrectExplained,
    CorrectJudgedImpossible,
    CorrectUndecided,
    CorrectTimeout,
    CorrectFailed,
    ImpossibleAtLine,
    ImpossibleElsewhere,
    ImpossibleExplained,
    ImpossibleUndecided,
    ImpossibleTimeout,
    ImpossibleFailed,
}

impl Category {
    pub fn label(&self) -> &'static str {
        match self {
            Category::CorrectExplained => "correct explained",
            Category::CorrectJudgedImpossible => "correct judged impossible",
            Category::CorrectUndecided => "correct undecided",
            Category::CorrectTimeout => "correct timeouts",
            Category::CorrectFailed => "correct replay failed to run",
            Category::ImpossibleAtLine => "impossible rejected at the right line",
            Category::ImpossibleElsewhere => "impossible rejected elsewhere",
            Category::ImpossibleExplained => "impossible explained",
            Category::ImpossibleUndecided => "impossible undecided",
            Category::ImpossibleTimeout => "impossible timeouts",
            Category::ImpossibleFailed => "impossible replay failed to run",
        }
    }

    pub fn is_right(&self) -> bool {
        matches!(self, Category::CorrectExplained | Category::ImpossibleAtLine)
    }
}

pub fn categorize(side: &Sidecar, verdict: &Verdict) -> Category {
    if side.expect == "impossible" {
        match verdict {
            Verdict::Impossible { line } if *line == side.impossible_line => Category::ImpossibleAtLine,
            Verdict::Impossible { .. } => Category::ImpossibleElsewhere,
            Verdict::Explained => Category::ImpossibleExplained,
            Verdict::Undecided => Category::ImpossibleUndecided,
            Verdict::Timeout => Category::ImpossibleTimeout,
            Verdict::Failed(_) => Category::ImpossibleFailed,
        }
    } else {
        match verdict {
            Verdict::Explained => Category::CorrectExplained,
            Verdict::Impossible { .. } => Category::CorrectJudgedImpossible,
            Verdict::Undecided => Category::CorrectUndecided,
            Verdict::Timeout => Category::CorrectTimeout,
            Verdict::Failed(_) => Category::CorrectFailed,
        }
    }
}

/// The furthest `(line L)` of replay's "failed at event N (line L)": where the combination
/// of readings that lasted longest died.
pub fn furthest_failure_line(output: &str) -> Option<usize> {
    let mut best = None;
    for (pos, _) in output.match_indices("failed at event ") {
        let rest = &output[pos..];
        if let Some(open) = rest.find("(line ") {
            let digits: String = rest[open + 6..].chars().take_while(char::is_ascii_digit).collect();
            if let Ok(n) = digits.parse::<usize>() {
                best = Some(best.map_or(n, |b: usize| b.max(n)));
            }
        }
    }
    best
}

/// Run `pmacwd replay LOG`; the verdict and the output (stdout then stderr).
pub fn replay(pmacwd: &Path, log: &Path, timeout: Duration) -> (Verdict, String) {
    let child = Command::new(pmacwd)
        .arg("replay")
        .arg(log)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn();
    let mut child = match child {
        Ok(c) => c,
        Err(e) => return (Verdict::Failed(format!("cannot run {}: {e}", pmacwd.display())), String::new()),
    };
    let mut out = child.stdout.take().expect("piped");
    let mut err = child.stderr.take().expect("piped");
    let out_thread = std::thread::spawn(move || {
        let mut s = String::new();
        let _ = out.read_to_string(&mut s);
        s
    });
    let err_thread = std::thread::spawn(move || {
        let mut s = String::new();
        let _ = err.read_to_string(&mut s);
        s
    });
    let start = Instant::now();
    let status = loop {
        match child.try_wait() {
            Ok(Some(status)) => break Some(status),
            Ok(None) if start.elapsed() >= timeout => {
                let _ = child.kill();
                let _ = child.wait();
                break None;
            }
            Ok(None) => std::thread::sleep(Duration::from_millis(20)),
            Err(e) => return (Verdict::Failed(format!("waiting for replay: {e}")), String::new()),
        }
    };
    let text = out_thread.join().unwrap_or_default() + &err_thread.join().unwrap_or_default();
    let verdict = match status.map(|s| s.code()) {
        None => Verdict::Timeout,
        Some(Some(0)) => Verdict::Explained,
        Some(Some(1)) => Verdict::Impossible { line: furthest_failure_line(&text) },
        Some(Some(2)) => Verdict::Undecided,
        Some(code) => Verdict::Failed(format!("exit {code:?}")),
    };
    (verdict, text)
}

pub struct Judged {
    pub sidecar: Sidecar,
    pub verdict: Verdict,
    pub category: Category,
    pub seconds: f64,
    pub output: String,
}

/// The sidecars of a directory, in name order.
pub fn sidecars(dir: &Path) -> Result<Vec<(PathBuf, Sidecar)>, String> {
    let entries = std::fs::read_dir(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let mut out = Vec::new();
    for entry in entries {
        let path = entry.map_err(|e| format!("{}: {e}", dir.display()))?.path();
        if path.extension().and_then(|e| e.to_str()) != Some("yaml") {
            continue;
        }
        let text = std::fs::read_to_string(&path).map_err(|e| format!("{}: {e}", path.display()))?;
        let side = Sidecar::from_yaml(&text).map_err(|e| format!("{}: {e}", path.display()))?;
        let log = path.with_extension("log");
        if !log.exists() {
            return Err(format!("{}: no {} beside it", path.display(), log.display()));
        }
        out.push((log, side));
    }
    out.sort_by(|a, b| a.1.name.cmp(&b.1.name));
    if out.is_empty() {
        return Err(format!("{}: no generated logs (NAME.yaml beside NAME.log)", dir.display()));
    }
    Ok(out)
}

/// Judge every log, `jobs` at a time; `progress` is called as each finishes.
pub fn judge_all(
    pmacwd: &Path,
    logs: Vec<(PathBuf, Sidecar)>,
    timeout: Duration,
    jobs: usize,
    progress: &(dyn Fn(&Judged) + Sync),
) -> Vec<Judged> {
    let next = AtomicUsize::new(0);
    let results = Mutex::new(Vec::new());
    std::thread::scope(|scope| {
        for _ in 0..jobs.max(1) {
            scope.spawn(|| loop {
                let i = next.fetch_add(1, Ordering::SeqCst);
                let Some((log, side)) = logs.get(i) else { break };
                let start = Instant::now();
                let (verdict, output) = replay(pmacwd, log, timeout);
                let category = categorize(side, &verdict);
                let judged =
                    Judged { sidecar: side.clone(), verdict, category, seconds: start.elapsed().as_secs_f64(), output };
                progress(&judged);
                results.lock().expect("no poisoned lock").push(judged);
            });
        }
    });
    let mut results = results.into_inner().expect("no poisoned lock");
    results.sort_by(|a, b| a.sidecar.name.cmp(&b.sidecar.name));
    results
}

/// The lines of replay's output worth showing for a misjudged log.
pub fn first_lines(output: &str, furthest: Option<usize>) -> Vec<String> {
    let mut lines = Vec::new();
    if let Some(l) =
        output.lines().find(|l| l.starts_with("verdict:") || l.starts_with("pmacwd:") || l.starts_with("error"))
    {
        lines.push(l.trim().to_string());
    }
    if let Some(n) = furthest {
        let key = format!("(line {n})");
        if let Some(l) = output.lines().find(|l| l.contains(&key)) {
            lines.push(l.trim().to_string());
        }
    } else if let Some(l) = output.lines().find(|l| l.contains("failed at")) {
        lines.push(l.trim().to_string());
    }
    if lines.is_empty() {
        lines.extend(output.lines().take(3).map(|l| l.trim().to_string()));
    }
    lines
}

/// The report: counts, counts per family, and every misjudged log.
pub fn report(results: &[Judged]) -> String {
    let mut out = String::new();
    let mut counts: BTreeMap<Category, usize> = BTreeMap::new();
    let mut families: BTreeMap<(String, String), (usize, usize)> = BTreeMap::new();
    for r in results {
        *counts.entry(r.category).or_default() += 1;
        let e = families.entry((r.sidecar.family.clone(), r.sidecar.expect.clone())).or_default();
        e.1 += 1;
        if r.category.is_right() {
            e.0 += 1;
        }
    }
    let correct = results.iter().filter(|r| r.sidecar.expect == "explained").count();
    let impossible = results.len() - correct;
    out.push_str(&format!("correct logs: {correct}\n"));
    for c in [
        Category::CorrectExplained,
        Category::CorrectJudgedImpossible,
        Category::CorrectUndecided,
        Category::CorrectTimeout,
        Category::CorrectFailed,
    ] {
        out.push_str(&format!("  {:<40} {}\n", c.label(), counts.get(&c).copied().unwrap_or(0)));
    }
    out.push_str(&format!("impossible logs: {impossible}\n"));
    for c in [
        Category::ImpossibleAtLine,
        Category::ImpossibleElsewhere,
        Category::ImpossibleExplained,
        Category::ImpossibleUndecided,
        Category::ImpossibleTimeout,
        Category::ImpossibleFailed,
    ] {
        out.push_str(&format!("  {:<40} {}\n", c.label(), counts.get(&c).copied().unwrap_or(0)));
    }
    // An impossible variant judged anywhere but its line says little when its correct log is
    // misjudged too: count those apart.
    let base_wrong = |name: &str| {
        let base = name.split("-impossible-").next().unwrap_or(name);
        results.iter().any(|b| b.sidecar.name == base && !b.category.is_right())
    };
    let moot = results
        .iter()
        .filter(|r| r.sidecar.expect == "impossible" && !r.category.is_right() && base_wrong(&r.sidecar.name))
        .count();
    out.push_str(&format!("  {:<40} {moot}\n", "(misjudged impossible whose correct log is misjudged too)"));
    out.push_str("by family (judged right / logs):\n");
    for ((family, expect), (right, all)) in &families {
        out.push_str(&format!("  {family:<20} {expect:<11} {right}/{all}\n"));
    }
    let wrong: Vec<&Judged> = results.iter().filter(|r| !r.category.is_right()).collect();
    if !wrong.is_empty() {
        out.push_str("misjudged:\n");
        for r in wrong {
            let furthest = match r.verdict {
                Verdict::Impossible { line } => line,
                _ => None,
            };
            let expected = match r.sidecar.impossible_line {
                Some(l) => {
                    format!(", impossible at line {l} ({})", r.sidecar.impossible_kind.clone().unwrap_or_default())
                }
                None => String::new(),
            };
            out.push_str(&format!("  {} [{}{}] {:.1} s\n", r.sidecar.name, r.category.label(), expected, r.seconds));
            if let Verdict::Failed(why) = &r.verdict {
                out.push_str(&format!("      {why}\n"));
            }
            for l in first_lines(&r.output, furthest) {
                out.push_str(&format!("      {l}\n"));
            }
        }
    }
    out
}
