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
    // Room for the EPICS driver's CPU-load figures (M70-M73, its CPULOAD PVs) as a third form
    // of the same loads: each would conflict with the unit and microsecond forms as these do.
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
/// (a third form, the EPICS driver's CPU-load figures, would go here).
#[derive(Clone, Copy, Debug)]
struct Given {
    plc0_us: Option<f64>,
    background_us: Option<f64>,
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
    let mut rows = Vec::new();
    for p in profiles {
        let cfg = match ModelConfig::from_spec(&spec, &a.configuration, &p) {
            Ok(c) => c,
            Err(e) => {
                eprintln!("pmacwd: --configuration {}: {}", a.configuration, e.message);
                return ExitCode::from(2);
            }
        };
        let cfg = match cfg.with_card(&spec, &card) {
            Ok(c) => c,
            Err(e) => {
                eprintln!("pmacwd: {}", e.replace("card: ", "--"));
                return ExitCode::from(2);
            }
        };
        let first = cfg.loads.first().copied().unwrap_or(Load { motors: 1, plc0_units: 0, background_units: 3 });
        // A time in µs is the configuration's units at its servo clock (the same for every
        // profile: none changes the clock or the costs).
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
        let load = Load {
            motors: a.motors.unwrap_or(first.motors),
            plc0_units: plc0.unwrap_or(first.plc0_units),
            background_units: background.unwrap_or(first.background_units),
        };
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
            json_document("margin", json_version::MARGIN, to_json(&a.configuration, load, given, readings, &rows))
        );
    } else {
        print!("{}", to_text(&a.configuration, load, given, readings, &rows));
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

/// `PLC 0 275 units: margin 3391 servo cycles; 276 units: the card trips; 277 units: margin 4135
/// servo cycles`.
fn neighbours_text(n: &NotMonotonic) -> String {
    let what = match n.cost {
        Cost::Plc0 => "PLC 0",
        Cost::Background => "background",
    };
    let points: Vec<String> = n
        .units
        .iter()
        .zip(&n.margin_cycles)
        .map(|(u, m)| match m {
            Some(c) => format!("{u} units: margin {c} servo cycles"),
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
        for n in &r.not_monotonic {
            let _ = writeln!(
                s,
                "  warning: the margin is not monotonic in the load here: {}; a load that varies around this one \
                 can meet the least of these (UM p.236: PLC 0 runs each RTI only once the last RTI's tasks are done)",
                neighbours_text(n)
            );
        }
    }
    s
}

fn to_json(
    configuration: &str,
    load: Load,
    given: Given,
    readings: Option<(i32, Option<i32>)>,
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
