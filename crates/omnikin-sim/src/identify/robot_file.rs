//! The robot file with the identified values: the input file's text with each fitted key's
//! line replaced by `key = value  # identified: value ± 1σ from <logs>` — every other line
//! (comments, limits, dynamics, events) kept byte for byte — and the gyro's bias and scale as
//! comments at the top (robot files have no gyro table).
//!
//! Keys are found on their own line inside their table (`[geometry]`, the N-th
//! `[[geometry.wheels]]` or `[[geometry.modules]]`). The result is read back and compared with
//! the fitted description, so a file the line editor cannot handle (a value split over several
//! lines, a key in an inline table) is refused with the key's name, never written wrong.

use omnikin::description::{Geometry, RobotDescription};

use super::{Estimate, Identified, IdentifyError, Status};

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

fn describe(e: &Estimate, shown: f64, sigma: f64, unit: &str) -> String {
    match &e.status {
        Status::Fitted => format!("{} ± {} {unit}", num(shown), num(sigma)),
        Status::Fixed(why) => format!("{} {unit} held: {why}", num(shown)),
    }
}

fn find<'a>(id: &'a Identified, name: &str) -> Option<&'a Estimate> {
    id.geometry.iter().find(|e| e.name == name)
}

fn edits(id: &Identified, from: &str) -> Vec<Edit> {
    let mut out = Vec::new();
    let src = format!("from {from}");
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
    out
}

/// `line`'s key if it is `key = …` (whitespace allowed around the key).
fn key_of(line: &str) -> Option<&str> {
    let (k, _) = line.split_once('=')?;
    let k = k.trim();
    (!k.is_empty() && !k.starts_with('#') && !k.starts_with('[')).then_some(k)
}

/// The robot file `text` (whose description is `prior`) with the values of `id` (see the
/// module docs); `from` names the logs in the comments.
///
/// # Errors
/// [`IdentifyError::Fit`] naming the key when a fitted key is not on its own line of its table,
/// or when the rewritten file does not read back as the fitted robot.
pub fn rewrite(text: &str, id: &Identified, from: &str) -> Result<String, IdentifyError> {
    let mut edits = edits(id, from);
    let mut lines: Vec<String> = Vec::new();
    let mut table = String::new();
    let mut counts: std::collections::HashMap<String, usize> = Default::default();
    for line in text.lines() {
        let t = line.trim();
        if t.starts_with('[') {
            table = t.split('#').next().unwrap_or("").trim().to_string();
            *counts.entry(table.clone()).or_insert(0) += 1;
            lines.push(line.to_string());
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
                let e = edits.remove(k);
                lines.push(format!("{} = {}  # {}", e.key, e.value, e.comment));
            }
            None => lines.push(line.to_string()),
        }
    }
    if let Some(e) = edits.first() {
        return Err(IdentifyError::Fit(format!(
            "cannot write the identified robot file: `{}` of {} #{} is not on a line of its own",
            e.key,
            e.table,
            e.index + 1
        )));
    }
    let mut head = String::new();
    for g in &id.gyro {
        head.push_str(&format!(
            "# identified {}: {} {from}\n",
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
    };
    if same {
        Ok(())
    } else {
        Err(IdentifyError::Fit(
            "the identified robot file does not read back as the fitted robot (a fitted key written in a form the line editor does not handle?)".into(),
        ))
    }
}
