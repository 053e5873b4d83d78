//! The SPIN twins of `timing` and `i40-zero` (model/spin/*.pml) explore as many states as the
//! checker does (issue 32): the two searches compared in docs/model.md do equal work only while this
//! holds. Needs `spin` and `gcc` on PATH (model/spin/run.sh installs spin from Debian when run
//! as root); without spin the test says it is skipped and passes.

use pmacwd_model::checker::WatchdogModel;
use pmacwd_specs::Spec;
use std::path::Path;
use std::process::Command;

fn on_path(program: &str) -> bool {
    std::env::var_os("PATH").is_some_and(|p| std::env::split_paths(&p).any(|d| d.join(program).is_file()))
}

/// The state count of the twin `model/spin/{configuration}.pml` and the checker's, under the
/// default profile; `None` when spin or gcc is missing.
fn counts(configuration: &str) -> Option<(usize, usize)> {
    if !on_path("spin") || !on_path("gcc") {
        eprintln!("skipped: spin or gcc not on PATH (apt-get install -y spin gcc)");
        return None;
    }
    let spec = Spec::embedded().expect("embedded specs load");
    let cfg = pmacwd_specs::config::ModelConfig::from_spec(&spec, configuration, &spec.profiles.default_profile())
        .expect("configuration resolves");
    assert_eq!(cfg.profile.name, "um-215", "the twins are written for the default profile");
    let checker = WatchdogModel::new(cfg).check(1).states;

    let work = std::env::temp_dir().join(format!("pmacwd-spin-twin-{configuration}-{}", std::process::id()));
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("spin/run.sh");
    let out = Command::new("sh").arg(&script).arg(configuration).env("SPIN_WORK", &work).output().expect("run.sh runs");
    let _ = std::fs::remove_dir_all(&work);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "run.sh failed:\n{stdout}\n{}", String::from_utf8_lossy(&out.stderr));
    let twin: usize = stdout
        .split(": ")
        .nth(1)
        .and_then(|rest| rest.split(' ').next())
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("no state count in run.sh's output:\n{stdout}"));
    Some((twin, checker))
}

#[test]
fn the_spin_twin_of_timing_has_the_checkers_state_count() {
    if let Some((twin, checker)) = counts("timing") {
        assert_eq!(twin, checker, "the twin explores {twin} states, the checker {checker}");
    }
}

#[test]
fn the_spin_twin_of_i40_zero_has_the_checkers_state_count() {
    if let Some((twin, checker)) = counts("i40-zero") {
        assert_eq!(twin, checker, "the twin explores {twin} states, the checker {checker}");
    }
}
