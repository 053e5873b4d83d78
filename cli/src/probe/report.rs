//! The probe's report: every reading and named profile supported, ruled out or undecided over
//! the segments a correct card explains; every fault with its exchange, what a correct card
//! could have answered and the manual page; the counts per kind; the figures of the run.

use super::campaign::CHECKS;
use super::check::Check;
use super::judge::Verdict;
use pmacwd_capture::explain::report::OptionVerdict;
use serde_json::json;
use std::fmt::Write;

pub struct Run {
    pub address: String,
    pub transport: &'static str,
    pub seed: u64,
    pub log: String,
    pub units: usize,
    pub lines: usize,
    pub campaign_seconds: f64,
    pub judge_seconds: f64,
    /// Units that ended early, and why (written in the log too).
    pub cut_short: Vec<(usize, String, String)>,
    pub verdict: Verdict,
}

fn over(v: &OptionVerdict) -> String {
    match v {
        OptionVerdict::Supported(_) => "supported".into(),
        OptionVerdict::RuledOut(d) => {
            format!("RULED OUT (line {}: {}: the card {}, this reading {})", d.line, d.what, d.expected, d.observed)
        }
    }
}

impl Run {
    /// Each kind of fault with its count, in the order of [`CHECKS`].
    pub fn fault_counts(&self) -> Vec<(&'static Check, usize)> {
        CHECKS
            .iter()
            .map(|c| (*c, self.verdict.faults.iter().filter(|f| std::ptr::eq(f.fault.check, *c)).count()))
            .filter(|(_, n)| *n > 0)
            .collect()
    }

    pub fn exit(&self) -> u8 {
        if !self.verdict.faults.is_empty() {
            1
        } else if !self.verdict.explained {
            2
        } else {
            0
        }
    }
}

pub fn text(run: &Run) -> String {
    let mut o = String::new();
    let v = &run.verdict;
    let _ = writeln!(
        o,
        "campaign: {} units, {} command lines in {:.1} s ({}, seed {})",
        run.units, run.lines, run.campaign_seconds, run.transport, run.seed
    );
    let _ = writeln!(o, "log: {} (judge it again: pmacwd replay {})", run.log, run.log);
    for (unit, name, why) in &run.cut_short {
        let _ = writeln!(o, "  unit {unit} ({name}) ended early: {why}");
    }
    let _ = writeln!(
        o,
        "judged: {} in {:.1} s (the whole log, then again without each unit that had a fault)",
        crate::common::plural(v.passes.len() as u64, "pass", "passes"),
        run.judge_seconds
    );
    if v.explained {
        let what = if v.faults.is_empty() { "the log" } else { "the log without the units that had a fault" };
        let _ = writeln!(o, "profiles (a correct card under it explains {what}):");
        for (name, default, explains) in &v.profiles {
            let d = if *default { " (default)" } else { "" };
            let _ = writeln!(o, "  {name}{d}: {}", if *explains { "supported" } else { "RULED OUT" });
        }
        let _ = writeln!(o, "readings:");
        for r in &v.readings {
            if let Some(why) = r.not_exercised {
                let _ = writeln!(o, "  {}: not exercised ({why})", r.reading);
                continue;
            }
            let decided = r.options.iter().any(|(_, x)| matches!(x, OptionVerdict::RuledOut(_)));
            let _ =
                writeln!(o, "  {}: {}", r.reading, if decided { "decided" } else { "undecided (both options fit)" });
            for (option, x) in &r.options {
                let _ = writeln!(o, "      {option}: {}", over(x));
            }
        }
    }
    if let Some(why) = &v.undecided {
        let _ = writeln!(o, "undecided: {why}");
    }
    let counts = run.fault_counts();
    if counts.is_empty() {
        let _ = writeln!(o, "faults: none");
    } else {
        let _ = writeln!(o, "faults: {} kinds, {} in all", counts.len(), v.faults.len());
        for (check, n) in &counts {
            let _ = writeln!(o, "  {} x{n}: {} ({})", check.id, check.what, check.cite);
            for f in v.faults.iter().filter(|f| std::ptr::eq(f.fault.check, *check)) {
                let x = &f.fault;
                let _ =
                    writeln!(
                    o,
                    "    unit {} ({}), line {}: `{}` answered `{}`; {}: this card {}, a correct card could answer {}",
                    if f.unit == super::campaign::START { "start".to_string() } else { f.unit.to_string() },
                    f.unit_name,
                    x.line, x.command, x.reply, x.what, x.card, x.correct
                );
            }
        }
    }
    let verdict = match run.exit() {
        1 => format!("verdict: NOT what a correct card can show: {} faults (exit 1)", v.faults.len()),
        2 => "verdict: no fault found, but no verdict on the rest either (exit 2)".to_string(),
        _ => "verdict: a correct card explains every exchange (exit 0)".to_string(),
    };
    let _ = writeln!(o, "{verdict}");
    o
}

pub fn json(run: &Run) -> serde_json::Value {
    let v = &run.verdict;
    let readings: Vec<_> = v
        .readings
        .iter()
        .map(|r| {
            let options: serde_json::Map<String, serde_json::Value> =
                r.options.iter().map(|(o, x)| (o.to_string(), json!(over(x)))).collect();
            json!({"reading": r.reading, "not_exercised": r.not_exercised, "options": options})
        })
        .collect();
    let profiles: Vec<_> =
        v.profiles.iter().map(|(n, d, e)| json!({"profile": n, "default": d, "supported": e})).collect();
    let faults: Vec<_> = v
        .faults
        .iter()
        .map(|f| {
            let x = &f.fault;
            json!({"kind": x.check.id, "cite": x.check.cite, "unit": f.unit, "unit_name": f.unit_name,
                   "line": x.line, "command": x.command, "reply": x.reply, "what": x.what,
                   "card_answered": x.card, "correct_card_could_answer": x.correct})
        })
        .collect();
    let counts: serde_json::Map<String, serde_json::Value> =
        run.fault_counts().iter().map(|(c, n)| (c.id.to_string(), json!(n))).collect();
    json!({
        "address": run.address, "transport": run.transport, "seed": run.seed, "log": run.log,
        "units": run.units, "command_lines": run.lines,
        "campaign_seconds": run.campaign_seconds, "judge_seconds": run.judge_seconds,
        "passes": v.passes.iter().map(|(left_out, s)| json!({"units_left_out": left_out, "seconds": s})).collect::<Vec<_>>(),
        "cut_short": run.cut_short.iter().map(|(u, n, w)| json!({"unit": u, "name": n, "why": w})).collect::<Vec<_>>(),
        "explained": v.explained, "undecided": v.undecided,
        "profiles": profiles, "readings": readings,
        "fault_counts": counts, "faults": faults, "exit": run.exit(),
    })
}
