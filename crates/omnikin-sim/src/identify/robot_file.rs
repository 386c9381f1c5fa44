//! The robot file with the identified values: the input file's text with each fitted key's
//! line replaced by `key = value  # identified: value ± 1σ` — every other line (comments,
//! limits, dynamics, events) kept byte for byte — and, at the top, a comment naming the logs it
//! was fitted on and the gyro's bias and scale (robot files have no gyro table).
//!
//! Keys are found on their own line inside their table (`[geometry]`, the N-th
//! `[[geometry.wheels]]` or `[[geometry.modules]]`). The result is read back and compared with
//! the fitted description, so a file the line editor cannot handle (a value split over several
//! lines, a key in an inline table) is refused with the key's name, never written wrong.

use omnikin::description::{Geometry, RobotDescription};

use super::{FitStatus, Identified, IdentifyError, ParameterEstimate};

/// One replacement: in table `table` (occurrence `index` for arrays of tables), key `key`.
struct Edit {
    table: &'static str,
    index: usize,
    key: &'static str,
    value: String,
    comment: String,
}

fn num(v: f64) -> String {
    let s = format!("{v:.9}");
    let s = s.trim_end_matches('0');
    let s = s
        .strip_suffix('.')
        .map_or(s.to_string(), |x| format!("{x}.0"));
    if s == "-0.0" { "0.0".into() } else { s }
}

fn describe(e: &ParameterEstimate, shown: f64, sigma: f64, unit: &str) -> String {
    match &e.status {
        FitStatus::Fitted => format!("{} ± {} {unit}", num(shown), num(sigma)),
        FitStatus::Fixed(_) => format!(
            "{} {unit} held at the prior (not identifiable from these runs)",
            num(shown)
        ),
    }
}

fn find<'a>(id: &'a Identified, name: &str) -> Option<&'a ParameterEstimate> {
    id.geometry.iter().find(|e| e.name == name)
}

fn edits(id: &Identified) -> Vec<Edit> {
    let mut out = Vec::new();
    let src = "(1σ)";
    match &id.description.geometry {
        Geometry::Omni(wheels) => {
            for (i, w) in wheels.iter().enumerate() {
                let n = i + 1;
                let (Some(s), Some(x), Some(y), Some(a)) = (
                    find(id, &format!("wheels[{n}].radius_scale")),
                    find(id, &format!("wheels[{n}].position.x")),
                    find(id, &format!("wheels[{n}].position.y")),
                    find(id, &format!("wheels[{n}].drive_angle")),
                ) else {
                    continue;
                };
                let r0 = w.radius / s.value;
                out.push(Edit {
                    table: "[[geometry.wheels]]",
                    index: i,
                    key: "radius",
                    value: num(w.radius),
                    comment: format!(
                        "identified: {} {src}",
                        describe(s, w.radius, s.sigma * r0, "m")
                    ),
                });
                out.push(Edit {
                    table: "[[geometry.wheels]]",
                    index: i,
                    key: "position",
                    value: format!("[{}, {}]", num(w.position[0]), num(w.position[1])),
                    comment: format!(
                        "identified: x {}, y {} {src}",
                        describe(x, x.value, x.sigma, "m"),
                        describe(y, y.value, y.sigma, "m")
                    ),
                });
                let deg = a.value.to_degrees();
                out.push(Edit {
                    table: "[[geometry.wheels]]",
                    index: i,
                    key: "drive_angle_deg",
                    value: num(deg),
                    comment: format!(
                        "identified: {} {src}",
                        describe(a, deg, a.sigma.to_degrees(), "deg")
                    ),
                });
            }
        }
        Geometry::Swerve { modules, .. } => {
            for (i, m) in modules.iter().enumerate() {
                let n = i + 1;
                let (Some(s), Some(x), Some(y)) = (
                    find(id, &format!("modules[{n}].radius_scale")),
                    find(id, &format!("modules[{n}].position.x")),
                    find(id, &format!("modules[{n}].position.y")),
                ) else {
                    continue;
                };
                let r0 = m.wheel_radius / s.value;
                out.push(Edit {
                    table: "[[geometry.modules]]",
                    index: i,
                    key: "wheel_radius",
                    value: num(m.wheel_radius),
                    comment: format!(
                        "identified: {} {src}",
                        describe(s, m.wheel_radius, s.sigma * r0, "m")
                    ),
                });
                out.push(Edit {
                    table: "[[geometry.modules]]",
                    index: i,
                    key: "position",
                    value: format!("[{}, {}]", num(m.position[0]), num(m.position[1])),
                    comment: format!(
                        "identified: x {}, y {} {src}",
                        describe(x, x.value, x.sigma, "m"),
                        describe(y, y.value, y.sigma, "m")
                    ),
                });
            }
        }
        Geometry::Caster(c) => {
            if let (Some(s), Some(d), Some(e)) = (
                find(id, "wheel_radius_scale"),
                find(id, "mount_radius"),
                find(id, "eccentricity"),
            ) {
                let r0 = c.wheel_radius / s.value;
                for (key, value, est, shown, sigma) in [
                    (
                        "wheel_radius",
                        c.wheel_radius,
                        s,
                        c.wheel_radius,
                        s.sigma * r0,
                    ),
                    ("mount_radius", c.mount_radius, d, d.value, d.sigma),
                    ("eccentricity", c.eccentricity, e, e.value, e.sigma),
                ] {
                    out.push(Edit {
                        table: "[geometry]",
                        index: 0,
                        key,
                        value: num(value),
                        comment: format!("identified: {} {src}", describe(est, shown, sigma, "m")),
                    });
                }
            }
        }
        Geometry::Sphere(sp) => {
            let parts: Vec<String> = (0..3)
                .filter_map(|i| {
                    let e = find(id, &format!("wheels[{}].radius_scale", i + 1))?;
                    let r0 = sp.wheel_radius[i] / e.value;
                    Some(describe(e, sp.wheel_radius[i], e.sigma * r0, "m"))
                })
                .collect();
            out.push(Edit {
                table: "[geometry]",
                index: 0,
                key: "wheel_radius",
                value: format!("[{}]", sp.wheel_radius.map(num).join(", ")),
                comment: format!("identified: {} {src}", parts.join("; ")),
            });
        }
        Geometry::Ballbot(b) => {
            if let Some(s) = find(id, "wheel_radius_scale") {
                let r0 = b.wheel_radius / s.value;
                out.push(Edit {
                    table: "[geometry]",
                    index: 0,
                    key: "wheel_radius",
                    value: num(b.wheel_radius),
                    comment: format!(
                        "identified: {} {src}",
                        describe(s, b.wheel_radius, s.sigma * r0, "m")
                    ),
                });
            }
        }
    }
    for (name, key, how) in [
        (super::COM_DEPTH, "com_depth", "the rocking after stops"),
        (
            super::ROLLING_RESISTANCE,
            "rolling_resistance",
            "the rocking after stops",
        ),
        (
            super::PIVOT_FRICTION,
            "pivot_friction",
            "the spin's decay after stops",
        ),
    ] {
        if let Some(e) = id
            .dynamics
            .iter()
            .find(|e| e.name == name && e.status == FitStatus::Fitted)
        {
            out.push(Edit {
                table: "[dynamics]",
                index: 0,
                key,
                value: num(e.value),
                comment: format!(
                    "identified: {} from {how} {src}",
                    describe(e, e.value, e.sigma, e.unit)
                ),
            });
        }
    }
    out
}

/// `line`'s key if it is `key = …` (whitespace allowed around the key).
fn key_of(line: &str) -> Option<&str> {
    let (k, _) = line.split_once('=')?;
    let k = k.trim();
    (!k.is_empty() && !k.starts_with('#') && !k.starts_with('[')).then_some(k)
}

/// The robot file `text` with the values of `id` (see the module docs); `from` names the logs
/// in the header comment.
///
/// # Errors
/// [`IdentifyError::Fit`] naming the key when a fitted key is not on its own line of its table,
/// or when the rewritten file does not read back as the fitted robot.
pub fn rewrite(text: &str, id: &Identified, from: &str) -> Result<String, IdentifyError> {
    let mut edits = edits(id);
    let mut lines: Vec<String> = Vec::new();
    let mut table = String::new();
    let mut counts: std::collections::HashMap<String, usize> = Default::default();
    // Where each table's first occurrence starts (the line after its header), for a key the
    // file leaves to a default or a named value (`floor = "vinyl"` gives rolling_resistance).
    let mut starts: std::collections::HashMap<String, usize> = Default::default();
    for line in text.lines() {
        let t = line.trim();
        if t.starts_with('[') {
            table = t.split('#').next().unwrap_or("").trim().to_string();
            *counts.entry(table.clone()).or_insert(0) += 1;
            lines.push(line.to_string());
            starts.entry(table.clone()).or_insert(lines.len());
            continue;
        }
        let index = counts.get(&table).map_or(0, |c| c.saturating_sub(1));
        let hit = key_of(t).and_then(|k| {
            edits
                .iter()
                .position(|e| e.table == table && e.index == index && e.key == k)
        });
        match hit {
            Some(k) => {
                let mut e = edits.remove(k);
                let old = t.split_once('=').map_or("", |(_, v)| v.trim());
                if old.starts_with('[') && !old.contains(']') {
                    return Err(IdentifyError::Fit(format!(
                        "cannot write the identified robot file: `{}` of {} #{} is written over several lines; write it on one line",
                        e.key,
                        e.table,
                        e.index + 1
                    )));
                }
                // An angle keeps the turn the file wrote it in (210°, not −150°).
                if e.key == "drive_angle_deg"
                    && let (Ok(new), Some(old)) = (
                        e.value.parse::<f64>(),
                        t.split_once('=')
                            .and_then(|(_, v)| v.split('#').next())
                            .and_then(|v| v.trim().parse::<f64>().ok()),
                    )
                {
                    e.value = num(new + 360.0 * ((old - new) / 360.0).round());
                    let shown = num(new);
                    e.comment = e.comment.replacen(&shown, &e.value, 1);
                }
                lines.push(format!("{} = {}  # {}", e.key, e.value, e.comment));
            }
            None => lines.push(line.to_string()),
        }
    }
    // Keys the file does not write (a default, or a value its named floor gives): a line of
    // their own at the top of their table, where an explicit value overrides the name. A key
    // written some other way (an inline table) would appear twice: the read-back check below
    // refuses that file.
    let mut inserted: Vec<(usize, String)> = Vec::new();
    edits.retain(|e| match starts.get(e.table) {
        Some(&at) if e.index == 0 => {
            inserted.push((at, format!("{} = {}  # {}", e.key, e.value, e.comment)));
            false
        }
        _ => true,
    });
    // From the bottom up, so that each position still means what it did; keys of one table
    // keep their order.
    let mut inserted: Vec<(usize, (usize, String))> = inserted.into_iter().enumerate().collect();
    inserted.sort_by_key(|(i, (at, _))| std::cmp::Reverse((*at, *i)));
    for (_, (at, line)) in inserted {
        lines.insert(at, line);
    }
    if let Some(e) = edits.first() {
        return Err(IdentifyError::Fit(format!(
            "cannot write the identified robot file: `{}` of {} #{} is not on a line of its own",
            e.key,
            e.table,
            e.index + 1
        )));
    }
    let mut head = format!("# identified by omnikin identify from {from}\n");
    for g in &id.gyro {
        head.push_str(&format!(
            "# identified {}: {} (1σ; robot files have no gyro table)\n",
            g.name,
            describe(g, g.value, g.sigma, g.unit)
        ));
    }
    let out = format!("{head}{}\n", lines.join("\n"));
    check(&out, &id.description)?;
    Ok(out)
}

/// The rewritten file reads back as `want` (to the digits written).
fn check(text: &str, want: &RobotDescription) -> Result<(), IdentifyError> {
    let back = RobotDescription::from_toml_str(text, "the identified robot file")
        .map_err(|e| IdentifyError::Fit(format!("the identified robot file does not load: {e}")))?;
    let close = |a: f64, b: f64| (a - b).abs() <= 1e-8 * (1.0 + b.abs());
    let same = match (&back.geometry, &want.geometry) {
        (Geometry::Omni(a), Geometry::Omni(b)) => {
            a.len() == b.len()
                && a.iter().zip(b).all(|(a, b)| {
                    close(a.radius, b.radius)
                        && close(a.position[0], b.position[0])
                        && close(a.position[1], b.position[1])
                        && close(a.drive[0], b.drive[0])
                        && close(a.drive[1], b.drive[1])
                })
        }
        (Geometry::Swerve { modules: a, .. }, Geometry::Swerve { modules: b, .. }) => {
            a.len() == b.len()
                && a.iter().zip(b).all(|(a, b)| {
                    close(a.wheel_radius, b.wheel_radius)
                        && close(a.position[0], b.position[0])
                        && close(a.position[1], b.position[1])
                })
        }
        (Geometry::Caster(a), Geometry::Caster(b)) => {
            close(a.wheel_radius, b.wheel_radius)
                && close(a.mount_radius, b.mount_radius)
                && close(a.eccentricity, b.eccentricity)
        }
        (Geometry::Sphere(a), Geometry::Sphere(b)) => {
            (0..3).all(|i| close(a.wheel_radius[i], b.wheel_radius[i]))
        }
        (Geometry::Ballbot(a), Geometry::Ballbot(b)) => close(a.wheel_radius, b.wheel_radius),
        _ => false,
    } && match (&back.sphere_dynamics, &want.sphere_dynamics) {
        (Some(a), Some(b)) => [
            (a.com_depth, b.com_depth),
            (a.rolling_resistance, b.rolling_resistance),
            (a.pivot_friction, b.pivot_friction),
        ]
        .into_iter()
        .all(|pair| match pair {
            (Some(x), Some(y)) => close(x, y),
            (x, y) => x == y,
        }),
        (a, b) => a.is_none() && b.is_none(),
    };
    if same {
        Ok(())
    } else {
        Err(IdentifyError::Fit(
            "the identified robot file does not read back as the fitted robot (a fitted key written in a form the line editor does not handle?)".into(),
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::identify::params;

    /// An identification of the kiwi preset with every value moved a little.
    fn moved(name: &str) -> (String, Identified) {
        let text = omnikin::description::PRESETS
            .iter()
            .find(|(n, _)| *n == name)
            .unwrap()
            .1
            .to_string();
        let prior = RobotDescription::from_toml_str(&text, name).unwrap();
        let ps = params::parameters(&prior);
        let values: Vec<f64> = ps.iter().map(|p| p.prior * 1.01 + 1e-3).collect();
        let id = Identified {
            description: params::apply(&prior, &values),
            geometry: ps
                .iter()
                .zip(&values)
                .map(|(p, v)| ParameterEstimate {
                    name: p.name.clone(),
                    unit: p.quantity.unit(),
                    prior: p.prior,
                    value: *v,
                    sigma: 1e-4,
                    status: FitStatus::Fitted,
                })
                .collect(),
            gyro: Vec::new(),
            dynamics: Vec::new(),
            rocking: Vec::new(),
            spin_decay: Vec::new(),
            position_rms: 0.0,
            heading_rms: None,
            gyro_rms: None,
            condition: 1.0,
            residuals: 0,
            series: Vec::new(),
        };
        (text, id)
    }

    #[test]
    fn every_kind_reads_back_as_the_fitted_robot_with_its_other_lines_kept() {
        for name in [
            "kiwi",
            "mecanum",
            "swerve4",
            "caster3",
            "sphere-omni",
            "ballbot",
        ] {
            let (text, id) = moved(name);
            let out = rewrite(&text, &id, "a.csv, b.csv").unwrap();
            assert!(out.starts_with("# identified by omnikin identify from a.csv, b.csv\n"));
            assert!(out.contains("# identified: "), "{name}");
            // Lines that carry no fitted key are kept verbatim.
            for line in text.lines().filter(|l| l.starts_with("max_wheel_rate")) {
                assert!(out.lines().any(|o| o == line), "{name}: {line}");
            }
        }
    }

    #[test]
    fn a_drive_angle_keeps_its_turn() {
        let (text, id) = moved("kiwi");
        let out = rewrite(&text, &id, "x").unwrap();
        // Wheel 2 was written as 210°; its fitted angle (atan2 gives −150°) stays near 210.
        let line = out
            .lines()
            .filter(|l| l.starts_with("drive_angle_deg"))
            .nth(1)
            .unwrap();
        let v: f64 = line[line.find('=').unwrap() + 1..line.find('#').unwrap()]
            .trim()
            .parse()
            .unwrap();
        assert!((180.0..240.0).contains(&v), "{line}");
    }

    #[test]
    fn a_value_over_several_lines_is_refused_with_its_key() {
        let (text, id) = moved("kiwi");
        let split = text.replacen(
            "position = [0.15, 0.0]",
            "position = [\n  0.15,\n  0.0,\n]",
            1,
        );
        let e = rewrite(&split, &id, "x").unwrap_err().to_string();
        assert!(
            e.contains("`position`") && e.contains("several lines"),
            "{e}"
        );
    }
}
