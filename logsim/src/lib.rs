//! pmacwd-logsim: an independent generator of host logs of correct and of impossible Turbo
//! PMAC cards, written from the manual pages alone (not from this project's model), and a
//! harness that judges `pmacwd replay` on them. docs/independent-logs.md has the rules with
//! their citations, the families, the format and how to run.

pub mod card;
pub mod families;
pub mod host;
pub mod judge;
pub mod rng;
pub mod sidecar;

use std::path::Path;

pub use families::{generate, log_seed, Generated, FAMILIES, LONG_FAMILIES};

/// The logs of one run: `count` base logs (the families in turn, or only `family`), each with
/// its impossible variant when one applies.
pub fn generate_set(seed: u64, count: u64, family: Option<&str>) -> Vec<Generated> {
    let mut out = Vec::new();
    for i in 0..count {
        let fam = match family {
            Some(f) => f,
            None => FAMILIES[(i % FAMILIES.len() as u64) as usize],
        };
        let (correct, impossible) = generate(fam, log_seed(seed, i));
        out.push(correct);
        out.extend(impossible);
    }
    out
}

/// Write NAME.log and NAME.yaml for each log into `dir` (created if missing).
pub fn write_set(dir: &Path, logs: &[Generated]) -> std::io::Result<()> {
    std::fs::create_dir_all(dir)?;
    for g in logs {
        std::fs::write(dir.join(format!("{}.log", g.name)), &g.log)?;
        std::fs::write(dir.join(format!("{}.yaml", g.name)), g.sidecar.to_yaml())?;
    }
    Ok(())
}
