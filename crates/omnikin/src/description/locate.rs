//! The line of a field's value in a description's TOML text, for errors that name the field.
//!
//! Validation works on deserialised values, which have lost their position; an error names
//! the field as a key path (`geometry.wheels[0].roller_angle_deg`, `limits.max_wheel_rate`).
//! [`value_line`] finds where that value is written, so the error points at the value's line
//! rather than at its table's `[[geometry.wheels]]` header (or at no line at all).

use toml::de::{DeTable, DeValue};

/// 1-based line where the value of the key path `field` starts in `text`, or `None` when the
/// path is not a key of the text (`file`, `kind` rules without a key), names a table (whose
/// values, not its header, are the offending text), or the text does not parse. Text after
/// the path's first space is ignored (`geometry.wheel_radius (wheel 1)`); `[i]` indexes an
/// array or an array of tables.
pub(super) fn value_line(text: &str, field: &str) -> Option<usize> {
    let path = field.split(' ').next()?;
    if path.is_empty() {
        return None;
    }
    let doc = DeTable::parse(text).ok()?;
    let mut table: &DeTable<'_> = doc.get_ref();
    let mut found: Option<(&DeValue<'_>, core::ops::Range<usize>)> = None;
    for segment in path.split('.') {
        if let Some((value, _)) = found {
            table = match value {
                DeValue::Table(t) => t,
                _ => return None,
            };
        }
        let (key, indices) = match segment.split_once('[') {
            Some((key, rest)) => (key, Some(rest)),
            None => (segment, None),
        };
        let (_, entry) = table.iter().find(|(k, _)| k.get_ref() == key)?;
        let (mut value, mut span) = (entry.get_ref(), entry.span());
        // `[i]` or `[i][j]`: index into arrays.
        for index in indices.into_iter().flat_map(|r| r.split('[')) {
            let i: usize = index.strip_suffix(']')?.parse().ok()?;
            let DeValue::Array(items) = value else {
                return None;
            };
            let item = items.get(i)?;
            (value, span) = (item.get_ref(), item.span());
        }
        found = Some((value, span));
    }
    let (value, span) = found?;
    if matches!(value, DeValue::Table(_)) {
        return None;
    }
    Some(1 + text[..span.start.min(text.len())].matches('\n').count())
}

#[cfg(test)]
mod tests {
    use super::value_line;

    const TEXT: &str = "kind = \"omni\"\n\
                        [[geometry.wheels]]\n\
                        position = [0.1, 0.0]\n\
                        radius = 0.05\n\
                        \n\
                        [[geometry.wheels]]\n\
                        # second\n\
                        position = [-0.1, 0.0]\n\
                        radius = -1\n\
                        [limits]\n\
                        max_wheel_rate = 40.0\n\
                        [dynamics]\n\
                        inertia = { x = 1.0, y = 2.0 }\n";

    #[test]
    fn finds_the_line_of_each_value() {
        assert_eq!(value_line(TEXT, "kind"), Some(1));
        assert_eq!(value_line(TEXT, "geometry.wheels[0].radius"), Some(4));
        assert_eq!(value_line(TEXT, "geometry.wheels[1].radius"), Some(9));
        assert_eq!(value_line(TEXT, "geometry.wheels[1].position"), Some(8));
        assert_eq!(value_line(TEXT, "geometry.wheels[1].position[1]"), Some(8));
        assert_eq!(value_line(TEXT, "limits.max_wheel_rate"), Some(11));
        assert_eq!(value_line(TEXT, "dynamics.inertia.y"), Some(13));
        assert_eq!(
            value_line(TEXT, "geometry.wheels[1].radius (wheel 2)"),
            Some(9)
        );
    }

    #[test]
    fn tables_missing_keys_and_bad_text_have_no_line() {
        assert_eq!(value_line(TEXT, "limits"), None);
        assert_eq!(value_line(TEXT, "geometry.wheels[1]"), None);
        assert_eq!(value_line(TEXT, "geometry.wheels[2].radius"), None);
        assert_eq!(value_line(TEXT, "limits.max_steer_rate"), None);
        assert_eq!(value_line(TEXT, "file"), None);
        assert_eq!(value_line(TEXT, ""), None);
        assert_eq!(value_line(TEXT, "kind.x"), None);
        assert_eq!(value_line(TEXT, "geometry.wheels[x].radius"), None);
        assert_eq!(value_line("kind = = 1", "kind"), None);
    }
}
