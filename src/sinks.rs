//! What left through the scene's sinks: `summary.json` → `sinks` and `sinks.csv`.
//!
//! Per sink: the particles and mass removed, and the discharge rate, the least-squares
//! slope of the removed mass against time over the checks at which between 20 % and 80 %
//! of the mass removed by the end of the run had left (the start-up of the flow and the
//! emptying, or the end of the run, left out). The rate's spread compares the slopes of
//! the window's two halves: a steady flow has them equal. A sink below an outlet measures
//! the outlet's mass flow rate, delayed by the fall from the outlet to the sink.
use grainflow_components::Sinks;
use serde_json::json;
use std::fmt::Write as _;
use std::path::Path;

/// Header line of `sinks.csv`: one line per check that removed particles, per sink, with
/// the totals of that sink so far.
pub const SINKS_CSV_HEADER: &str = "time,sink,name,count,mass,removed,removed_mass\n";

/// Least-squares slope of `m` against `t`, if the points are at least 3 at 2 times.
fn slope(t: &[f64], m: &[f64]) -> Option<f64> {
    let n = t.len() as f64;
    if t.len() < 3 {
        return None;
    }
    let (tm, mm) = (t.iter().sum::<f64>() / n, m.iter().sum::<f64>() / n);
    let sxx: f64 = t.iter().map(|x| (x - tm) * (x - tm)).sum();
    let sxy: f64 = t.iter().zip(m).map(|(x, y)| (x - tm) * (y - mm)).sum();
    (sxx > 0.0).then(|| sxy / sxx)
}

/// The steady discharge rate of one sink from its (time, removed mass so far) records:
/// (rate, window start, window end, spread).
pub fn discharge_rate(time: &[f64], removed_mass: &[f64]) -> Option<(f64, f64, f64, f64)> {
    let total = *removed_mass.last()?;
    let window: Vec<usize> = (0..time.len())
        .filter(|&k| removed_mass[k] >= 0.2 * total && removed_mass[k] <= 0.8 * total)
        .collect();
    let (t, m): (Vec<f64>, Vec<f64>) = window.iter().map(|&k| (time[k], removed_mass[k])).unzip();
    let rate = slope(&t, &m)?;
    let half = t.len() / 2;
    let spread = match (slope(&t[..half], &m[..half]), slope(&t[half..], &m[half..])) {
        (Some(a), Some(b)) if rate != 0.0 => ((a - b) / rate).abs(),
        _ => f64::NAN,
    };
    Some((rate, t[0], t[t.len() - 1], spread))
}

/// The (time, removed mass so far) of every check that removed some, through the sink
/// `only` or through all sinks together.
fn history(sinks: &Sinks, only: Option<u32>) -> (Vec<f64>, Vec<f64>) {
    let (mut t, mut m) = (Vec::<f64>::new(), Vec::<f64>::new());
    for e in sinks
        .events
        .iter()
        .filter(|e| only.is_none_or(|s| e.sink == s))
    {
        let before = m.last().copied().unwrap_or(0.0);
        if t.last() == Some(&e.time) {
            *m.last_mut().expect("one per time") += e.mass;
        } else {
            t.push(e.time);
            m.push(before + e.mass);
        }
    }
    (t, m)
}

/// `summary.json` → `observables`: the discharge rate (kg/s) through all sinks together
/// and its spread, as [`discharge_rate`]; empty if no sink has a steady window yet.
pub fn observables(sinks: &Sinks) -> serde_json::Map<String, serde_json::Value> {
    let (t, m) = history(sinks, None);
    let mut out = serde_json::Map::new();
    if let Some((rate, _, _, spread)) = discharge_rate(&t, &m) {
        out.insert("discharge_rate".into(), json!(rate));
        out.insert(
            "discharge_rate_spread".into(),
            json!(Some(spread).filter(|x| x.is_finite())),
        );
    }
    out
}

/// `summary.json` → `sinks`.
pub fn summary(sinks: &Sinks) -> serde_json::Value {
    sinks
        .list
        .iter()
        .enumerate()
        .map(|(s, sink)| {
            let (t, m) = history(sinks, Some(s as u32));
            let rate = discharge_rate(&t, &m);
            json!({
                "name": sink.name,
                "removed": sinks.removed[s],
                "removed_mass": sinks.removed_mass[s],
                "first_removal_time": t.first(),
                "last_removal_time": t.last(),
                "discharge_rate": rate.map(|r| r.0),
                "discharge_window": rate.map(|r| [r.1, r.2]),
                "discharge_rate_spread": rate.map(|r| r.3).filter(|x| x.is_finite()),
            })
        })
        .collect()
}

/// Write `sinks.csv` into `dir`.
pub fn write_csv(sinks: &Sinks, dir: &Path) -> Result<(), String> {
    let mut text = String::from(SINKS_CSV_HEADER);
    let mut count = vec![0u64; sinks.list.len()];
    let mut mass = vec![0.0; sinks.list.len()];
    for e in &sinks.events {
        let s = e.sink as usize;
        count[s] += e.count;
        mass[s] += e.mass;
        let _ = writeln!(
            text,
            "{:.9e},{s},\"{}\",{},{:.9e},{},{:.9e}",
            e.time, sinks.list[s].name, e.count, e.mass, count[s], mass[s]
        );
    }
    let path = dir.join("sinks.csv");
    std::fs::write(&path, text).map_err(|e| format!("cannot write {}: {e}", path.display()))
}
