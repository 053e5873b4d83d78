//! `pmacwd margin`: how close a configuration runs to a watchdog trip, under each profile,
//! measured on the model (`pmacwd_capture::margin`), as text, JSON, or a plot of the margin
//! against PLC 0 load.

use crate::common::{json_document, json_version, load_spec, Format};
use pmacwd_capture::margin::{self, Cost, Margin, NotMonotonic, ReadingMargin};
use pmacwd_specs::check::Load;
use pmacwd_specs::config::{servo_hz_of_i10, CardConfig, ModelConfig};
use pmacwd_specs::profiles::Profile;
use std::path::PathBuf;
use std::process::ExitCode;

/// The options of `pmacwd margin` (its help text is main.rs's, on the variant).
#[derive(clap::Args, Debug)]
pub struct MarginArgs {
    /// The check.yaml configuration to start from.
    #[arg(long, value_name = "NAME", default_value = "i40-zero")]
    pub configuration: String,
    /// Only this profile (default: every profile).
    #[arg(long, value_name = "NAME")]
    pub profile: Option<String>,
    /// Servo clock in Hz.
    #[arg(long, allow_negative_numbers = true, value_name = "HZ", value_parser = crate::common::servo_hz)]
    pub servo_hz: Option<u32>,
    /// Servo clock as I10 (SRM p.43: 8,388,608,000 / I10 Hz).
    #[arg(long, value_name = "I10", allow_negative_numbers = true, value_parser = crate::common::ranged(1i64, 8_388_607, " (SRM p.43)"))]
    pub i10: Option<i64>,
    /// I8: the RTI comes every I8 + 1 servo cycles.
    #[arg(long, value_name = "N", allow_negative_numbers = true, value_parser = crate::common::ranged(0i64, 255, " (I8's range, variables.yaml)"))]
    pub i8: Option<i64>,
    /// I40: the watchdog counter's reload (0: 4095 or 4096 by the profile's reading).
    #[arg(long, value_name = "N", allow_negative_numbers = true, value_parser = crate::common::ranged(0i64, 65_535, " (I40's range, variables.yaml)"))]
    pub i40: Option<i64>,
    /// Motors closed by the servo routines.
    #[arg(long, allow_negative_numbers = true, value_name = "N", value_parser = crate::common::ranged(0u8, u8::MAX, ""))]
    pub motors: Option<u8>,
    /// PLC 0 cost per RTI, in the configuration's CPU units.
    #[arg(long, allow_negative_numbers = true, value_name = "UNITS", value_parser = crate::common::ranged(0u16, u16::MAX, ""))]
    pub plc0_units: Option<u16>,
    /// PLC 0 time per RTI in microseconds (a scan time you measured), converted to the
    /// configuration's CPU units by its servo cycle (UM p.236), rounded up; not with
    /// --plc0-units.
    #[arg(long, value_name = "US", conflicts_with = "plc0_units", allow_negative_numbers = true, value_parser = crate::common::micros)]
    pub plc0_us: Option<f64>,
    /// CPU units one background cycle needs.
    #[arg(long, allow_negative_numbers = true, value_name = "UNITS", value_parser = crate::common::ranged(0u16, u16::MAX, ""))]
    pub background_units: Option<u16>,
    /// CPU time one background cycle needs, in microseconds, converted as --plc0-us; not with
    /// --background-units.
    #[arg(long, value_name = "US", conflicts_with = "background_units", allow_negative_numbers = true, value_parser = crate::common::micros)]
    pub background_us: Option<f64>,
    /// M70 as the EPICS pmac driver reads it (X:$FFFF8C: timer increments between phase
    /// interrupts, UM p.239), with --m71: the card's scale of its timer registers.
    #[arg(long, value_name = "VALUE", allow_negative_numbers = true, requires = "m71", value_parser = crate::common::ranged(1u32, 0xFF_FFFF, " (a 24-bit register, divided by: UM p.239)"))]
    pub m70: Option<u32>,
    /// M71 (X:$000037: the phase tasks' increments, UM p.239), below M70.
    #[arg(long, value_name = "VALUE", allow_negative_numbers = true, requires = "m70", value_parser = crate::common::ranged(0u32, 0xFF_FFFF, " (a 24-bit register, UM p.239)"))]
    pub m71: Option<u32>,
    /// M72 (Y:$000037: the last servo tasks, UM p.239), with --m70 and --m71: the motors, by the
    /// inverse of the model's mapping (pmacwd_core::timers); not with --motors.
    #[arg(long, value_name = "VALUE", allow_negative_numbers = true, requires = "m70", conflicts_with = "motors", value_parser = crate::common::ranged(0u32, 0xFF_FFFF, " (a 24-bit register, UM p.239)"))]
    pub m72: Option<u32>,
    /// M73 (X:$00000B: the last RTI tasks, UM p.239), with --m70 and --m71: PLC 0's units per
    /// RTI, by the same inverse; not with --plc0-units or --plc0-us.
    #[arg(long, value_name = "VALUE", allow_negative_numbers = true, requires = "m70", conflicts_with_all = ["plc0_units", "plc0_us"], value_parser = crate::common::ranged(0u32, 0xFF_FFFF, " (a 24-bit register, UM p.239)"))]
    pub m73: Option<u32>,
    /// The CPU load in percent, as the EPICS pmac driver's CPULOAD PV shows it (its sum of UM
    /// p.240's phase, servo and RTI duty cycles from M70-M73): PLC 0's units, and the motors
    /// unless --motors gives them; the phase share from --m70/--m71, or none. Not with --m72,
    /// --m73, --plc0-units or --plc0-us.
    #[arg(long, value_name = "PERCENT", allow_negative_numbers = true, conflicts_with_all = ["m72", "m73", "plc0_units", "plc0_us"], value_parser = crate::common::percent)]
    pub cpu_load: Option<f64>,
    /// I7002, as the EPICS driver reads it for its CPU load: I7002 + 1 phase interrupts a servo
    /// interrupt (SRM p.43; default: variables.yaml's).
    #[arg(long, value_name = "N", allow_negative_numbers = true, value_parser = crate::common::ranged(0u32, 15, " (the servo clock divider's range, MODEL)"))]
    pub i7002: Option<u32>,
    /// A measured X:$25 (`RHX:$25`: the lowest watchdog counter value since reset, SRM p.57), as
    /// the card replies (six hex digits: 000FF0, FFFFFF = -1), as $FF0, or decimal: also say,
    /// per profile, the longest run without a background cycle it proves and how many servo
    /// cycles were left to a trip at that point.
    #[arg(long, value_name = "VALUE", allow_negative_numbers = true, value_parser = crate::common::card_reading)]
    pub x25: Option<i32>,
    /// A measured Y:$25 (`RHY:$25`: the counter now), in the forms --x25 takes, with --x25: also
    /// say how long ago the last background cycle was.
    #[arg(long, value_name = "VALUE", requires = "x25", allow_negative_numbers = true, value_parser = crate::common::card_reading)]
    pub y25: Option<i32>,
    /// Output format: text, or one JSON document (docs/json.md gives its schema).
    #[arg(long, value_enum, default_value_t = Format::Text)]
    pub format: Format,
    /// The same as `--format json`: the flag before `--format`, kept for scripts.
    #[arg(long, conflicts_with = "format")]
    pub json: bool,
    /// Also draw the margin against PLC 0 load as an SVG plot, the load given marked on it.
    #[arg(long, value_name = "FILE")]
    pub plot: Option<PathBuf>,
    /// Spec directory to use instead of the embedded one.
    #[arg(long, value_name = "DIR")]
    pub specs: Option<PathBuf>,
}

/// One profile's figures, with the worst case over the strobe minimum's band.
struct Row {
    profile: Profile,
    default: bool,
    cfg: ModelConfig,
    stated: Margin,
    /// The same load with the shortest hardware delay the band admits (UM p.215 gives the
    /// strobe minimum only approximately; watchdog.yaml).
    shortest_delay: Margin,
    /// What --x25 (and --y25) say under this profile.
    reading: Option<ReadingMargin>,
    /// Where the margin grows with the load around the one given (`margin::not_monotonic`).
    not_monotonic: Vec<NotMonotonic>,
}

/// How the load's costs were given: in the configuration's CPU units or in microseconds
/// (the EPICS driver's figures are [`Figures`]).
#[derive(Clone, Copy, Debug)]
struct Given {
    plc0_us: Option<f64>,
    background_us: Option<f64>,
}

/// The EPICS pmac driver's CPU figures as given: the timer registers M70-M73 as it reads them
/// (DiamondLightSource/pmac `etc/bootstrap/BRICK_M_variables.pmc:70-73`: M70->X:$FFFF8C,
/// M71->X:$37, M72->Y:$37, M73->X:$B, UM p.239) and its CPU load, `P74 = 100 x (P71 + P72 +
/// P73)` (`pmacApp/src/pmacController.cpp:1850-1890`, after UM p.240's PLC).
#[derive(Clone, Copy, Debug)]
struct Figures {
    m70: Option<u32>,
    m71: Option<u32>,
    m72: Option<u32>,
    m73: Option<u32>,
    cpu_load: Option<f64>,
    /// I7002 + 1 phase interrupts a servo interrupt (SRM p.43), as the driver reads it.
    i7002: u32,
}

impl Figures {
    /// Whether a figure that stands for a load was given (M70 and M71 alone set only a scale).
    fn given(&self) -> bool {
        self.m72.is_some() || self.m73.is_some() || self.cpu_load.is_some()
    }
}

/// What the driver's figures became: every load they can stand for, and the one measured.
#[derive(Clone, Debug)]
struct FromFigures {
    figures: Figures,
    /// `--cpu-load` without M70 and M71: the phase tasks' share taken as none.
    phase_assumed: bool,
    /// Every (motors, PLC 0 units) the figures stand for, in the order searched.
    candidates: Vec<(u8, u16)>,
    /// The one with the smallest margin over the profiles measured.
    chosen: Load,
}

/// I7002's default from `variables.yaml` (3: four phase interrupts a servo interrupt).
fn default_i7002(spec: &pmacwd_specs::Spec) -> u32 {
    spec.variables.host_i_variables.iter().find(|v| v.number == "I7002").map_or(3, |v| v.default as u32)
}

/// M70's card-defined value in `variables.yaml` (the emulated Geo Brick's phase period), the
/// scale of `--cpu-load` given without M70 and M71: the duty cycles are ratios, so any period
/// gives the same shares up to the registers' rounding.
fn default_m70(spec: &pmacwd_specs::Spec) -> u32 {
    spec.variables.host_m_variables.iter().find(|v| v.number == "M70").map_or(13279, |v| v.value as u32)
}

/// The loads the driver's figures stand for, each by the inverse of the one mapping of the
/// model's CPU units to timer increments (`pmacwd_core::timers`, MODEL: the units in
/// proportion to what the phase tasks leave), as (motors, PLC 0 units), with whether the phase
/// share was assumed. `load` is the load as the other flags give it; `motors_given` whether
/// `--motors` was.
///
/// - M72, the servo tasks: the motors whose servo units (`servo_units_per_motor` each) read it
///   (MODEL: the model charges servo tasks only per motor, so any other servo task counts as
///   motors).
/// - M73, the RTI tasks after those servo tasks: PLC 0's units (MODEL: margin runs no motion
///   program, so no move planning: the RTI's units are PLC 0's).
/// - The CPU load: the PLC 0 units that, after the phase tasks (M70/M71's share, or none) and
///   the motors' servo tasks, make the driver's figure; without `--motors`, every motor count
///   whose phase and servo tasks fit the figure, since the figure does not say how it splits
///   between servo and RTI tasks.
///
/// Where the inverse is not unique (a reading between two unit counts' readings, or a split
/// the figure leaves open) every reading is returned; [`smallest_margin`] takes one.
fn loads_of_figures(
    f: &Figures,
    cfg: &ModelConfig,
    spec: &pmacwd_specs::Spec,
    load: Load,
    motors_given: bool,
) -> Result<(Vec<(u8, u16)>, bool), String> {
    use pmacwd_core::timers::{units_of, TimerScale, UnitsRange};
    let phase_assumed = f.m70.is_none();
    let (m70, m71) = (f.m70.unwrap_or_else(|| default_m70(spec)), f.m71.unwrap_or(0));
    if m71 >= m70 {
        return Err(format!(
            "--m71 {m71}: the phase tasks would take the whole phase period (--m70 {m70}); on a running card M71 is \
             below M70 (UM p.239)"
        ));
    }
    let scale = TimerScale {
        phase_period: m70,
        phase_task: m71,
        phases_per_servo: f.i7002 + 1,
        cycle_units: cfg.cpu.cycle_units,
    };
    let per_motor = u32::from(cfg.cpu.servo_units_per_motor);
    let i8 = cfg.saved.i8;
    let ends = |r: UnitsRange| if r.least == r.most { vec![r.least] } else { vec![r.least, r.most] };
    let motors: Vec<u8> = match (f.m72, f.cpu_load) {
        (Some(m72), _) => {
            let r = units_of(u64::from(m72), u32::from(u8::MAX), |m| u64::from(scale.servo_task(m * per_motor)))
                .ok_or_else(|| {
                    format!(
                        "--m72 {m72}: more than the servo tasks of {} motors read ({} at {per_motor} unit{} a motor)",
                        u8::MAX,
                        scale.servo_task(u32::from(u8::MAX) * per_motor),
                        if per_motor == 1 { "" } else { "s" }
                    )
                })?;
            ends(r).into_iter().map(|m| m as u8).collect()
        }
        (None, Some(_)) if !motors_given => (0..=u8::MAX).collect(),
        _ => vec![load.motors],
    };
    let target_ppm = f.cpu_load.map(|p| (p * 10_000.0).round() as u64);
    let mut loads = Vec::new();
    for m in motors {
        let servo = u32::from(m) * per_motor;
        let plc0: Vec<u32> = match (f.m73, target_ppm) {
            (Some(m73), _) => {
                let r = units_of(u64::from(m73), u32::from(u16::MAX), |u| u64::from(scale.rti_task(u, servo)))
                    .ok_or_else(|| {
                        format!(
                            "--m73 {m73}: more than {} units of PLC 0 read after the servo tasks of {m} motors ({})",
                            u16::MAX,
                            scale.rti_task(u32::from(u16::MAX), servo)
                        )
                    })?;
                ends(r)
            }
            (None, Some(ppm)) => {
                // The phase and servo tasks alone already read more than the figure: not this
                // split.
                let read = |u: u32| scale.timers(servo, u).load_ppm(scale.phases_per_servo, i8);
                if read(0) > ppm {
                    if motors_given || m == 0 {
                        return Err(format!(
                            "--cpu-load {}: the phase tasks{}{} alone make {:.2}%, more than the figure",
                            f.cpu_load.unwrap_or(0.0),
                            if phase_assumed { " (none, without --m70/--m71)" } else { " of --m70/--m71" },
                            if m == 0 { String::new() } else { format!(" and the servo tasks of {m} motors") },
                            read(0) as f64 / 10_000.0
                        ));
                    }
                    break;
                }
                match units_of(ppm, u32::from(u16::MAX), read) {
                    Some(r) => ends(r),
                    None => continue,
                }
            }
            (None, None) => vec![u32::from(load.plc0_units)],
        };
        loads.extend(plc0.into_iter().map(|u| (m, u as u16)));
    }
    if loads.is_empty() {
        return Err(format!(
            "--cpu-load {}: no load of the configuration's units makes this figure",
            f.cpu_load.unwrap_or(0.0)
        ));
    }
    Ok((loads, phase_assumed))
}

/// Of the loads the figures stand for, the one whose smallest margin over the profiles is the
/// smallest (a load that trips the card first): MODEL, a safety tool reads an open figure as
/// the load that leaves the least margin. The first such in the order searched.
fn smallest_margin(cfgs: &[(Profile, ModelConfig)], candidates: &[(u8, u16)], background_units: u16) -> Load {
    let mut best: Option<(Option<i64>, Load)> = None;
    for &(motors, plc0_units) in candidates {
        let load = Load { motors, plc0_units, background_units };
        // `Option`'s order puts `None` (the card trips) below every margin.
        let worst = cfgs.iter().map(|(_, cfg)| margin::measure(cfg, load).margin_cycles()).min().flatten();
        if best.as_ref().is_none_or(|(b, _)| worst < *b) {
            best = Some((worst, load));
        }
    }
    best.map_or(Load { motors: 0, plc0_units: 0, background_units }, |(_, l)| l)
}

fn ms(cfg: &ModelConfig, cycles: f64) -> f64 {
    cycles * 1000.0 / f64::from(cfg.servo_hz)
}

pub fn margin(a: MarginArgs) -> ExitCode {
    let spec = match load_spec(&a.specs) {
        Ok(s) => s,
        Err(code) => return code,
    };
    let servo_hz = match (a.servo_hz, a.i10) {
        (Some(_), Some(_)) => {
            eprintln!("pmacwd: give the servo clock as --servo-hz or as --i10, not both");
            return ExitCode::from(2);
        }
        (_, Some(i10)) => match servo_hz_of_i10(i10) {
            Some(hz) => Some(hz),
            None => {
                eprintln!("pmacwd: --i10 {i10}: I10 is 1 to 8,388,607 (SRM p.43)");
                return ExitCode::from(2);
            }
        },
        (hz, None) => hz,
    };
    let card = CardConfig { servo_hz, i8: a.i8, i40: a.i40, ..CardConfig::default() };
    let profiles: Vec<Profile> = match &a.profile {
        Some(name) => match spec.profiles.all().into_iter().find(|p| &p.name == name) {
            Some(p) => vec![p],
            None => {
                eprintln!("pmacwd: --profile {name}: no such profile (profiles: {})", spec.profiles.names());
                return ExitCode::from(2);
            }
        },
        None => spec.profiles.all(),
    };
    let default = spec.profiles.default_profile().name;
    let mut cfgs = Vec::new();
    for p in profiles {
        let cfg = match ModelConfig::from_spec(&spec, &a.configuration, &p) {
            Ok(c) => c,
            Err(e) => {
                eprintln!("pmacwd: --configuration {}: {}", a.configuration, e.message);
                return ExitCode::from(2);
            }
        };
        match cfg.with_card(&spec, &card) {
            Ok(c) => cfgs.push((p, c)),
            Err(e) => {
                eprintln!("pmacwd: {}", e.replace("card: ", "--"));
                return ExitCode::from(2);
            }
        }
    }
    let Some(cfg) = cfgs.first().map(|(_, c)| c.clone()) else {
        eprintln!("pmacwd: no profile to measure");
        return ExitCode::from(2);
    };
    // The load, the same for every profile: none changes the clock or the costs, so a time in
    // µs is the same units under each.
    let first = cfg.loads.first().copied().unwrap_or(Load { motors: 1, plc0_units: 0, background_units: 3 });
    let units = |units: Option<u16>, us: Option<f64>, flag: &str| match (units, us) {
        (Some(u), _) => Ok(Some(u)),
        (None, Some(us)) => margin::units_of_us(&cfg, us).map(Some).map_err(|e| format!("--{flag} {e}")),
        (None, None) => Ok(None),
    };
    let (plc0, background) = match (
        units(a.plc0_units, a.plc0_us, "plc0-us"),
        units(a.background_units, a.background_us, "background-us"),
    ) {
        (Ok(p), Ok(b)) => (p, b),
        (Err(e), _) | (_, Err(e)) => {
            eprintln!("pmacwd: {e}");
            return ExitCode::from(2);
        }
    };
    let mut load = Load {
        motors: a.motors.unwrap_or(first.motors),
        plc0_units: plc0.unwrap_or(first.plc0_units),
        background_units: background.unwrap_or(first.background_units),
    };
    let figures = Figures {
        m70: a.m70,
        m71: a.m71,
        m72: a.m72,
        m73: a.m73,
        cpu_load: a.cpu_load,
        i7002: a.i7002.unwrap_or_else(|| default_i7002(&spec)),
    };
    let from_figures = if figures.given() {
        match loads_of_figures(&figures, &cfg, &spec, load, a.motors.is_some()) {
            Ok((candidates, phase_assumed)) => {
                let chosen = smallest_margin(&cfgs, &candidates, load.background_units);
                load = chosen;
                Some(FromFigures { figures, phase_assumed, candidates, chosen })
            }
            Err(e) => {
                eprintln!("pmacwd: {e}");
                return ExitCode::from(2);
            }
        }
    } else {
        None
    };
    let mut rows = Vec::new();
    for (p, cfg) in cfgs {
        let stated = margin::measure(&cfg, load);
        let mut short = cfg.clone();
        short.hardware_delay_cycles = cfg.hardware_delay_band.0;
        let shortest_delay = margin::measure(&short, load);
        let reading = a.x25.map(|x| margin::from_readings(&cfg, load, x, a.y25));
        let not_monotonic = margin::not_monotonic(&cfg, load);
        rows.push((
            load,
            Row { default: p.name == default, profile: p, cfg, stated, shortest_delay, reading, not_monotonic },
        ));
    }
    let Some((load, _)) = rows.first().map(|(l, r)| (*l, r)) else {
        eprintln!("pmacwd: no profile to measure");
        return ExitCode::from(2);
    };
    if let Some(path) = &a.plot {
        if let Err(e) = plot(path, &rows.iter().map(|(_, r)| r).collect::<Vec<_>>(), load) {
            eprintln!("pmacwd: {}: cannot write the plot: {e}", path.display());
            return ExitCode::from(2);
        }
    }
    let rows: Vec<Row> = rows.into_iter().map(|(_, r)| r).collect();
    let given = Given { plc0_us: a.plc0_us, background_us: a.background_us };
    let readings = a.x25.map(|x| (x, a.y25));
    if a.format.or_json(a.json) == Format::Json {
        println!(
            "{}",
            json_document(
                "margin",
                json_version::MARGIN,
                to_json(&a.configuration, load, given, readings, from_figures.as_ref(), &rows)
            )
        );
    } else {
        print!("{}", to_text(&a.configuration, load, given, readings, from_figures.as_ref(), &rows));
    }
    // A load that trips the card under the default profile is a finding, not an error; so are
    // readings no profile's card can show.
    let readings_impossible = rows.iter().all(|r| matches!(r.reading, Some(ReadingMargin::Impossible(_))));
    if rows.iter().any(|r| r.default && r.stated.tripped) || readings_impossible {
        ExitCode::from(1)
    } else {
        ExitCode::SUCCESS
    }
}

/// A counter value as the card's `RHX:$25` replies it (six hex digits, 24 bits) and in decimal.
fn reading_text(v: i32) -> String {
    format!("{:06X} ({v})", v & 0xFF_FFFF)
}

/// What the EPICS driver's figures became: the figures, the load read from them, and, where
/// they stand for more than one load, which was measured and why.
fn figures_text(f: &FromFigures) -> String {
    let g = &f.figures;
    let mut given = Vec::new();
    if let (Some(m70), Some(m71)) = (g.m70, g.m71) {
        given.push(format!("M70 = {m70}, M71 = {m71}"));
    }
    given.extend(g.m72.map(|v| format!("M72 = {v}")));
    given.extend(g.m73.map(|v| format!("M73 = {v}")));
    given.extend(g.cpu_load.map(|p| format!("CPU load {p}%")));
    given.push(format!("I7002 = {}", g.i7002));
    let phase = if f.phase_assumed {
        " (no M70/M71: the phase tasks taken as none, so every percent is servo or RTI work, the most the figure can \
         mean)"
    } else {
        ""
    };
    let mut s = format!(
        "  from the EPICS driver's figures: {}{phase}, read back through the model's timer mapping (UM p.239-240, \
         pmacwd_core::timers): {} motor{}, PLC 0 {} units per RTI\n",
        given.join(", "),
        f.chosen.motors,
        if f.chosen.motors == 1 { "" } else { "s" },
        f.chosen.plc0_units
    );
    if f.candidates.len() > 1 {
        let span = |v: Vec<u16>| {
            let (lo, hi) = (v.iter().min().copied().unwrap_or(0), v.iter().max().copied().unwrap_or(0));
            if lo == hi {
                format!("{lo}")
            } else {
                format!("{lo} to {hi}")
            }
        };
        s.push_str(&format!(
            "  not unique: {} loads read so (motors {}, PLC 0 {} units); measured: the one with the smallest margin \
             over the profiles (MODEL: a safety tool takes the reading that leaves the least margin)\n",
            f.candidates.len(),
            span(f.candidates.iter().map(|c| u16::from(c.0)).collect()),
            span(f.candidates.iter().map(|c| c.1).collect())
        ));
    }
    s
}

/// `PLC 0 133.3 µs = 30 units`, for a cost given in µs.
fn converted(what: &str, us: Option<f64>, units: u16, cfg: &ModelConfig) -> Option<String> {
    us.map(|us| {
        format!(
            "{what} {us} µs = {units} unit{} ({:.3} exact, rounded up)",
            if units == 1 { "" } else { "s" },
            us / margin::us_per_unit(cfg)
        )
    })
}

/// `PLC 0 275 units: margin 3391 servo cycles; 276 units: the card trips; 277 units: margin 4112
/// to 4135 servo cycles`.
fn neighbours_text(n: &Neighbours) -> String {
    let what = match n.cost {
        Cost::Plc0 => "PLC 0",
        Cost::Background => "background",
    };
    let points: Vec<String> = n
        .units
        .iter()
        .zip(&n.margins)
        .map(|(u, m)| match m {
            Some((lo, hi)) if lo == hi => format!("{u} units: margin {lo} servo cycles"),
            Some((lo, hi)) => format!("{u} units: margin {lo} to {hi} servo cycles"),
            None => format!("{u} units: the card trips"),
        })
        .collect();
    format!("{what} {}", points.join("; "))
}

fn to_text(
    configuration: &str,
    load: Load,
    given: Given,
    readings: Option<(i32, Option<i32>)>,
    figures: Option<&FromFigures>,
    rows: &[Row],
) -> String {
    use std::fmt::Write as _;
    let mut s = String::new();
    let c = &rows[0].cfg;
    let _ = writeln!(
        s,
        "margin: configuration {configuration} (servo clock {} Hz, I8 = {}, I40 = {}); load: {} motor{}, PLC 0 {} units per \
         RTI, background {} units, of {} units per servo cycle ({} per motor)",
        c.servo_hz,
        c.saved.i8,
        c.saved.i40,
        load.motors,
        if load.motors == 1 { "" } else { "s" },
        load.plc0_units,
        load.background_units,
        c.cpu.cycle_units,
        c.cpu.servo_units_per_motor
    );
    let conversions: Vec<String> = [
        converted("PLC 0", given.plc0_us, load.plc0_units, c),
        converted("background", given.background_us, load.background_units, c),
    ]
    .into_iter()
    .flatten()
    .collect();
    if !conversions.is_empty() {
        let _ = writeln!(
            s,
            "  in µs: {}; a unit is {:.3} µs, a servo cycle of {:.1} µs (UM p.236, SRM p.43) over the {} units of \
             check.yaml",
            conversions.join(", "),
            margin::us_per_unit(c),
            1_000_000.0 / f64::from(c.servo_hz),
            c.cpu.cycle_units
        );
    }
    if let Some(f) = figures {
        s.push_str(&figures_text(f));
    }
    if let Some((x, y)) = readings {
        let _ = writeln!(
            s,
            "  readings: X:$25 = {}{}",
            reading_text(x),
            y.map_or(String::new(), |y| format!(", Y:$25 = {}", reading_text(y)))
        );
    }
    for r in rows {
        let (m, cfg) = (&r.stated, &r.cfg);
        let tag = if r.default { " (default)" } else { "" };
        let _ = writeln!(
            s,
            "{}{tag}: reload {} ({}), hardware delay {} servo cycles (strobe minimum {} Hz, UM p.215; {} to {} within \
             the band of watchdog.yaml)",
            r.profile.name,
            m.reload,
            margin::reload_cite(cfg),
            m.hardware_delay_cycles,
            cfg.profile.choices.strobe_hz_min.hz(),
            cfg.hardware_delay_band.0,
            cfg.hardware_delay_band.1
        );
        let _ = writeln!(
            s,
            "  tolerated: a background cycle within {} servo cycles of the last ({:.1} ms); with none the card trips \
             at cycle {} (UM p.215)",
            m.trip_after_cycles - 1,
            ms(cfg, (m.trip_after_cycles - 1) as f64),
            m.trip_after_cycles
        );
        match m.longest_interval_cycles {
            Some(g) => {
                let _ = writeln!(
                    s,
                    "  needed: the load completes a background cycle at least every {g} servo cycle{} ({:.2} ms); X:$25 \
                     settles at {}",
                    if g == 1 { "" } else { "s" },
                    ms(cfg, g as f64),
                    m.counter_min
                );
            }
            None => {
                let _ =
                    writeln!(s, "  needed: no background cycle completes under this load: the background is starved");
            }
        }
        match (m.margin_cycles(), r.shortest_delay.margin_cycles()) {
            (Some(c), Some(w)) => {
                let _ = writeln!(
                    s,
                    "  margin: {c} servo cycles ({:.1} ms); {w} ({:.1} ms) if the card's strobe minimum is at the top of \
                     its band (delay {})",
                    ms(cfg, c as f64),
                    ms(cfg, w as f64),
                    r.shortest_delay.hardware_delay_cycles
                );
            }
            _ => {
                let _ = writeln!(s, "  margin: NONE: the card trips under this load");
            }
        }
        match &r.reading {
            None => {}
            Some(ReadingMargin::Impossible(why)) => {
                let _ = writeln!(s, "  readings: IMPOSSIBLE under this profile: {why}");
            }
            Some(ReadingMargin::Seen { longest_gap_cycles, spare_cycles, since_last_background_cycles }) => {
                let _ = writeln!(
                    s,
                    "  readings: since reset the card went {longest_gap_cycles} servo cycles ({:.1} ms) without a background \
                     cycle (X:$25, SRM p.57); at that point {spare_cycles} more ({:.1} ms) were left before a trip",
                    ms(cfg, *longest_gap_cycles as f64),
                    ms(cfg, *spare_cycles as f64)
                );
                if let Some(n) = since_last_background_cycles {
                    let _ = writeln!(
                        s,
                        "  readings: the last background cycle was {n} servo cycles ({:.1} ms) before Y:$25 was read",
                        ms(cfg, *n as f64)
                    );
                }
            }
        }
        let _ = writeln!(
            s,
            "  RTI: {}; servo routines: {}",
            if m.rti_overran {
                "PLC 0 and the RTI tasks overran the RTI period (bit 22, SRM p.289)"
            } else {
                "no overrun"
            },
            if m.servo_overloaded { "MORE than a servo cycle (bit 20, SRM p.289)" } else { "fit the servo cycle" }
        );
    }
    // Each place the margin is not monotonic once, with the profiles it applies to (the
    // profiles' margins differ by their reloads and delays, not by where they fall).
    for (profiles, n) in not_monotonic_groups(rows) {
        let _ = writeln!(
            s,
            "warning: the margin is not monotonic in the load here, under {}: {}; a load that varies around this \
             one can meet the least of these (UM p.236: PLC 0 runs each RTI only once the last RTI's tasks are done)",
            if profiles.len() == rows.len() && rows.len() > 1 {
                format!("every profile measured ({})", profiles.join(", "))
            } else {
                profiles.join(", ")
            },
            neighbours_text(&n)
        );
    }
    s
}

/// The profiles' [`NotMonotonic`] findings, one per place: the same cost, the same loads and the
/// same loads tripping the card, with the names of the profiles it holds under and each load's
/// margins over them (least, most).
fn not_monotonic_groups(rows: &[Row]) -> Vec<(Vec<String>, Neighbours)> {
    let mut groups: Vec<(Vec<String>, Neighbours)> = Vec::new();
    for r in rows {
        for n in &r.not_monotonic {
            let trips: Vec<bool> = n.margin_cycles.iter().map(Option::is_none).collect();
            let same = |g: &Neighbours| {
                g.cost == n.cost
                    && g.units == n.units
                    && g.margins.iter().map(Option::is_none).collect::<Vec<_>>() == trips
            };
            match groups.iter_mut().find(|(_, g)| same(g)) {
                Some((names, g)) => {
                    names.push(r.profile.name.clone());
                    for (m, new) in g.margins.iter_mut().zip(&n.margin_cycles) {
                        if let (Some((lo, hi)), Some(c)) = (m.as_mut(), new) {
                            *lo = (*lo).min(*c);
                            *hi = (*hi).max(*c);
                        }
                    }
                }
                None => groups.push((
                    vec![r.profile.name.clone()],
                    Neighbours {
                        cost: n.cost,
                        units: n.units.clone(),
                        margins: n.margin_cycles.iter().map(|m| m.map(|c| (c, c))).collect(),
                    },
                )),
            }
        }
    }
    groups
}

/// One place the margin is not monotonic, over the profiles it holds under: each load's margin
/// as (least, most) over them, `None` where the card trips.
struct Neighbours {
    cost: Cost,
    units: Vec<u16>,
    margins: Vec<Option<(i64, i64)>>,
}

fn to_json(
    configuration: &str,
    load: Load,
    given: Given,
    readings: Option<(i32, Option<i32>)>,
    figures: Option<&FromFigures>,
    rows: &[Row],
) -> serde_json::Value {
    let profiles: Vec<serde_json::Value> = rows
        .iter()
        .map(|r| {
            let m = &r.stated;
            serde_json::json!({
                "profile": r.profile.name, "default": r.default, "reload": m.reload,
                "hardware_delay_cycles": m.hardware_delay_cycles,
                "hardware_delay_band": [r.cfg.hardware_delay_band.0, r.cfg.hardware_delay_band.1],
                "trip_after_cycles": m.trip_after_cycles,
                "tolerated_interval_cycles": m.trip_after_cycles - 1,
                "longest_interval_cycles": m.longest_interval_cycles,
                "counter_min": m.counter_min, "rti_overran": m.rti_overran,
                "servo_overloaded": m.servo_overloaded, "tripped": m.tripped,
                "margin_cycles": m.margin_cycles(),
                "margin_ms": m.margin_cycles().map(|c| ms(&r.cfg, c as f64)),
                "margin_cycles_shortest_delay": r.shortest_delay.margin_cycles(),
                "not_monotonic": r.not_monotonic.iter().map(|n| serde_json::json!({
                    "load": n.cost.key(), "units": n.units, "margin_cycles": n.margin_cycles,
                })).collect::<Vec<_>>(),
                "readings": r.reading.as_ref().map(|reading| match reading {
                    ReadingMargin::Impossible(why) => serde_json::json!({"possible": false, "why": why}),
                    ReadingMargin::Seen { longest_gap_cycles, spare_cycles, since_last_background_cycles } => serde_json::json!({
                        "possible": true, "longest_gap_cycles": longest_gap_cycles,
                        "longest_gap_ms": ms(&r.cfg, *longest_gap_cycles as f64),
                        "spare_cycles": spare_cycles, "spare_ms": ms(&r.cfg, *spare_cycles as f64),
                        "since_last_background_cycles": since_last_background_cycles,
                    }),
                }),
            })
        })
        .collect();
    let c = &rows[0].cfg;
    serde_json::json!({
        "configuration": configuration, "servo_hz": c.servo_hz, "i8": c.saved.i8, "i40": c.saved.i40,
        "load": {"motors": load.motors, "plc0_units": load.plc0_units, "background_units": load.background_units,
                 "plc0_us": given.plc0_us, "background_us": given.background_us},
        "cycle_units": c.cpu.cycle_units, "us_per_unit": margin::us_per_unit(c),
        "x25": readings.map(|r| r.0), "y25": readings.and_then(|r| r.1),
        "figures": figures.map(|f| serde_json::json!({
            "m70": f.figures.m70, "m71": f.figures.m71, "m72": f.figures.m72, "m73": f.figures.m73,
            "cpu_load_percent": f.figures.cpu_load, "i7002": f.figures.i7002,
            "phase_share_assumed": f.phase_assumed,
            "candidates": f.candidates.iter().map(|(m, u)| serde_json::json!({"motors": m, "plc0_units": u})).collect::<Vec<_>>(),
            "chosen": {"motors": f.chosen.motors, "plc0_units": f.chosen.plc0_units},
        })),
        "profiles": profiles,
    })
}

/// A plotted line: (PLC 0 units, margin in ms) at every unit.
type Curve = Vec<(f64, f64)>;

/// Profiles whose curves are the same, point for point: one line each, in the order of
/// `curves`; each group's first name leads and the rest are "same as" it.
fn coinciding(curves: Vec<(String, Curve)>) -> Vec<(Vec<String>, Curve)> {
    let mut groups: Vec<(Vec<String>, Curve)> = Vec::new();
    for (name, pts) in curves {
        match groups.iter_mut().find(|(_, p)| *p == pts) {
            Some((names, _)) => names.push(name),
            None => groups.push((vec![name], pts)),
        }
    }
    groups
}

/// Margin in ms against PLC 0 units per RTI, one line per profile, from no PLC 0 to twice
/// the RTI period's units (or beyond the load given), the load given marked on every line.
/// Profiles whose curves coincide are one line whose legend says which ("same: ..."); lines
/// that still overlap are told apart by width and dashes, the widest drawn first.
fn plot(path: &std::path::Path, rows: &[&Row], load: Load) -> Result<(), Box<dyn std::error::Error>> {
    use plotters::prelude::*;
    let cfg = &rows[0].cfg;
    let period = u32::from(cfg.saved.i8) + 1;
    let span = u32::from(cfg.cpu.cycle_units) * period * 2;
    let plc0_max =
        span.max(u32::from(load.plc0_units) + u32::from(cfg.cpu.cycle_units)).min(u32::from(u16::MAX)) as u16;
    let curves: Vec<(String, Curve)> = rows
        .iter()
        .map(|r| {
            // Every unit: the band where PLC 0 takes exactly the spare time and starves the
            // background can be a few units wide.
            let pts = margin::sweep_plc0(&r.cfg, load, plc0_max, plc0_max)
                .into_iter()
                .map(|(u, m)| (f64::from(u), m.margin_cycles().map_or(0.0, |c| ms(&r.cfg, c as f64))))
                .collect();
            let tag = if r.default { " (default)" } else { "" };
            (format!("{}{tag}", r.profile.name), pts)
        })
        .collect();
    let groups = coinciding(curves);
    // The load given, on each line: its margin at the load's own PLC 0 (the sweep has every
    // unit, so that point is on the line).
    let x = f64::from(load.plc0_units);
    let given: Vec<f64> =
        groups.iter().filter_map(|(_, pts)| pts.iter().find(|(u, _)| *u == x).map(|(_, y)| *y)).collect();
    let top = groups.iter().flat_map(|(_, p)| p.iter().map(|(_, y)| *y)).fold(1.0f64, f64::max);
    let root = SVGBackend::new(path, (1000, 560)).into_drawing_area();
    root.fill(&WHITE)?;
    let mut chart = ChartBuilder::on(&root)
        .caption(
            format!(
                "margin to a watchdog trip against PLC 0 load: {} Hz, I8 = {}, I40 = {}, {} motors, background {} units",
                cfg.servo_hz, cfg.saved.i8, cfg.saved.i40, load.motors, load.background_units
            ),
            ("sans-serif", 18),
        )
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(70)
        .build_cartesian_2d(0f64..f64::from(plc0_max), 0f64..top * 1.25)?;
    chart
        .configure_mesh()
        .x_desc(format!(
            "PLC 0 CPU units per RTI (an RTI period is {} units; a unit is {:.3} µs)",
            u32::from(cfg.cpu.cycle_units) * period,
            margin::us_per_unit(cfg)
        ))
        .y_desc("margin, ms (0: the card trips)")
        .y_label_formatter(&|v| format!("{v:.0}"))
        .x_label_formatter(&|v| format!("{v:.0}"))
        .draw()?;
    let count = groups.len();
    for (i, (names, pts)) in groups.into_iter().enumerate() {
        let color = Palette99::pick(i).to_rgba();
        // Widest first, so a line drawn later over the same stretch leaves it showing.
        let width = 2 + 2 * (count - 1 - i) as u32;
        let label =
            if names.len() == 1 { names[0].clone() } else { format!("{}; same: {}", names[0], names[1..].join(", ")) };
        let style = color.stroke_width(width);
        let series = if i == 0 {
            chart.draw_series(LineSeries::new(pts, style))?
        } else {
            chart.draw_series(DashedLineSeries::new(pts, 4 + 4 * i as i32, 4, style))?
        };
        series
            .label(label)
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], color.stroke_width(width)));
    }
    // The load given: a vertical line at its PLC 0 and a ring on each line where it meets it.
    chart
        .draw_series(DashedLineSeries::new(vec![(x, 0.0), (x, top * 1.25)], 6, 4, BLACK.stroke_width(1)))?
        .label(format!("your load: PLC 0 {} units per RTI", load.plc0_units))
        .legend(|(x, y)| Circle::new((x + 10, y), 5, BLACK.stroke_width(2)));
    chart.draw_series(given.iter().map(|y| Circle::new((x, *y), 6, BLACK.stroke_width(2))))?;
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::LowerLeft)
        .border_style(BLACK)
        .background_style(WHITE.mix(0.9))
        .draw()?;
    root.present()?;
    Ok(())
}
