//! `pmacwd-logsim`: write host logs of correct and impossible cards, or judge `pmacwd replay`
//! on a directory of them (docs/independent-logs.md).

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Duration;

use pmacwd_logsim::{generate_set, judge, write_set, FAMILIES, LONG_FAMILIES};

const HELP: &str = "\
pmacwd-logsim: host logs of correct and of impossible Turbo PMAC cards, from a simulator
written from the manual pages alone (docs/independent-logs.md), and a harness for
`pmacwd replay`.

USAGE:
  pmacwd-logsim --out DIR --seed S --count N [--family F]
      Write N logs (the families in turn, or only F), each as DIR/NAME.log (the host-log
      format of docs/capturing.md) and DIR/NAME.yaml (family, seed, readings chosen,
      expect: explained | impossible, impossible_line, cause of a trip). Each correct log is
      followed by its impossible variant when one applies. Deterministic in S.
  pmacwd-logsim judge DIR [--pmacwd PATH] [--timeout SECS] [--jobs N]
      Run `PATH replay NAME.log` on every log of DIR (default PATH target/release/pmacwd,
      timeout 120 s per log, 1 job) and print the counts: correct explained / judged
      impossible / undecided / timeouts; impossible rejected at the right line / elsewhere /
      explained; then the misjudged logs with replay's first lines. Exit 0 when every log is
      judged right, 1 when one is not, 2 for bad arguments.
  pmacwd-logsim --list-families
  pmacwd-logsim --help
";

fn usage(msg: &str) -> ExitCode {
    eprintln!("pmacwd-logsim: {msg}\n\n{HELP}");
    ExitCode::from(2)
}

fn value<'a>(args: &'a [String], i: &mut usize, flag: &str) -> Result<&'a str, String> {
    *i += 1;
    args.get(*i).map(String::as_str).ok_or_else(|| format!("{flag} needs a value"))
}

fn number<T: std::str::FromStr>(text: &str, flag: &str) -> Result<T, String> {
    text.parse().map_err(|_| format!("{flag}: `{text}` is not a non-negative whole number"))
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.is_empty() || args.iter().any(|a| a == "--help" || a == "-h") {
        print!("{HELP}");
        return if args.is_empty() { ExitCode::from(2) } else { ExitCode::SUCCESS };
    }
    if args[0] == "--list-families" {
        for f in FAMILIES {
            println!("{f}");
        }
        for f in LONG_FAMILIES {
            println!("{f} (only with --family)");
        }
        return ExitCode::SUCCESS;
    }
    if args[0] == "judge" {
        return match judge_command(&args[1..]) {
            Ok(code) => code,
            Err(msg) => usage(&msg),
        };
    }
    match generate_command(&args) {
        Ok(code) => code,
        Err(msg) => usage(&msg),
    }
}

fn generate_command(args: &[String]) -> Result<ExitCode, String> {
    let (mut out, mut seed, mut count, mut family) = (None, None, None, None);
    let mut i = 0;
    while i < args.len() {
        match args[i].as_str() {
            "--out" => out = Some(PathBuf::from(value(args, &mut i, "--out")?)),
            "--seed" => seed = Some(number::<u64>(value(args, &mut i, "--seed")?, "--seed")?),
            "--count" => count = Some(number::<u64>(value(args, &mut i, "--count")?, "--count")?),
            "--family" => {
                let f = value(args, &mut i, "--family")?;
                if !pmacwd_logsim::families::is_family(f) {
                    return Err(format!(
                        "--family: no family `{f}`; the families are {}, {}",
                        FAMILIES.join(", "),
                        LONG_FAMILIES.join(", ")
                    ));
                }
                family = Some(f.to_string());
            }
            other => return Err(format!("unknown argument `{other}`")),
        }
        i += 1;
    }
    let out = out.ok_or("--out DIR is required")?;
    let seed = seed.ok_or("--seed S is required")?;
    let count = count.ok_or("--count N is required")?;
    if count == 0 {
        return Err("--count must be at least 1".into());
    }
    let logs = generate_set(seed, count, family.as_deref());
    write_set(&out, &logs).map_err(|e| format!("writing {}: {e}", out.display()))?;
    let impossible = logs.iter().filter(|g| g.sidecar.expect == "impossible").count();
    println!(
        "pmacwd-logsim: wrote {} logs to {} ({} correct, {impossible} impossible), seed {seed}",
        logs.len(),
        out.display(),
        logs.len() - impossible
    );
    Ok(ExitCode::SUCCESS)
}

fn judge_command(args: &[String]) -> Result<ExitCode, String> {
    let mut dir = None;
    let mut pmacwd = PathBuf::from("target/release/pmacwd");
    let mut timeout = 120u64;
    let mut jobs = 1usize;
    let mut i = 0;
    while i < args.len() {
        match args[i].as_str() {
            "--pmacwd" => pmacwd = PathBuf::from(value(args, &mut i, "--pmacwd")?),
            "--timeout" => timeout = number(value(args, &mut i, "--timeout")?, "--timeout")?,
            "--jobs" => jobs = number(value(args, &mut i, "--jobs")?, "--jobs")?,
            a if a.starts_with("--") => return Err(format!("unknown argument `{a}`")),
            a if dir.is_none() => dir = Some(PathBuf::from(a)),
            a => return Err(format!("one directory only, `{a}` is a second")),
        }
        i += 1;
    }
    let dir = dir.ok_or("judge needs a directory of generated logs")?;
    if timeout == 0 || jobs == 0 {
        return Err("--timeout and --jobs must be at least 1".into());
    }
    if !pmacwd.exists() {
        return Err(format!(
            "--pmacwd: {} does not exist (build it: cargo build --release -p pmacwd-cli --locked)",
            pmacwd.display()
        ));
    }
    let logs = judge::sidecars(&dir)?;
    let total = logs.len();
    let done = std::sync::atomic::AtomicUsize::new(0);
    let progress = |j: &judge::Judged| {
        let n = done.fetch_add(1, std::sync::atomic::Ordering::SeqCst) + 1;
        eprintln!("[{n}/{total}] {} {:.1} s: {}", j.sidecar.name, j.seconds, j.category.label());
    };
    let results = judge::judge_all(&pmacwd, logs, Duration::from_secs(timeout), jobs, &progress);
    print!("{}", judge::report(&results));
    let all_right = results.iter().all(|r| r.category.is_right());
    Ok(if all_right { ExitCode::SUCCESS } else { ExitCode::from(1) })
}
