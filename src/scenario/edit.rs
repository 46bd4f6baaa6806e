//! Setting one value of a scenario by its path in the text (`nekosim run --set PATH=VALUE`, a
//! sweep's axes): the value's text is replaced, or a missing field is added to its struct, and
//! the result is parsed and checked again like any scenario file, so the field's own type
//! decides what the new value may be.

use super::locate::spans;

/// Where a path did not lead.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum EditError {
    #[error("no value at `{0}` (a path is fields and indices, e.g. `robots[0].count`, `network.lambda`)")]
    Unknown(String),
    #[error("`{0}` is not a struct: its fields cannot be added to")]
    NotAStruct(String),
}

/// `text` with the value at `path` replaced by `value` (RON text). A path is fields joined by
/// `.` and list or tuple indices in brackets (`robots[0].born`, `stack[1].protocol.timeout`);
/// enum and struct names are not part of it. A field the text leaves out (to its default) is
/// added to the struct that would hold it.
pub fn set(text: &str, path: &str, value: &str) -> Result<String, EditError> {
    let s = spans(text);
    if let Some(r) = s.ranges.get(path) {
        return Ok(format!("{}{value}{}", &text[..r.start], &text[r.end..]));
    }
    // A field left out: added right after its struct's opening parenthesis.
    let (parent, field) = match path.rfind('.') {
        Some(i) => (&path[..i], &path[i + 1..]),
        None => ("", path),
    };
    let is_name = !field.is_empty()
        && field.chars().all(|c| c.is_alphanumeric() || c == '_')
        && !field.starts_with(|c: char| c.is_ascii_digit());
    let Some(r) = s.ranges.get(parent).filter(|_| is_name) else {
        return Err(EditError::Unknown(path.to_string()));
    };
    let inner = &text[r.clone()];
    let open = inner
        .find('(')
        .filter(|&i| inner[..i].chars().all(|c| c.is_alphanumeric() || c == '_'))
        .ok_or_else(|| EditError::NotAStruct(parent.to_string()))?;
    // Tuples and newtypes have no named fields: `(1.0, 2.0)`, `Some(3)`.
    let rest = inner[open + 1..].trim_start();
    let named = rest.starts_with(')') || {
        let name_end = rest
            .find(|c: char| !(c.is_alphanumeric() || c == '_'))
            .unwrap_or(rest.len());
        name_end > 0 && rest[name_end..].trim_start().starts_with(':')
    };
    if !named {
        return Err(EditError::NotAStruct(parent.to_string()));
    }
    let at = r.start + open + 1;
    Ok(format!("{}{field}: {value}, {}", &text[..at], &text[at..]))
}

#[cfg(test)]
mod tests {
    use super::*;

    const SRC: &str = "Scenario(\n  world: (size: Bounded(width: 800.0, height: 800.0)),\n  robots: [Group(count: 10, radius: 5.0)],\n  network: Poisson(lambda: 1.0),\n)";

    #[test]
    fn replaces_a_value_in_place() {
        let t = set(SRC, "robots[0].count", "200").unwrap();
        assert!(t.contains("Group(count: 200, radius: 5.0)"), "{t}");
        let t = set(SRC, "network.lambda", "10.0").unwrap();
        assert!(t.contains("Poisson(lambda: 10.0)"), "{t}");
        let t = set(SRC, "world.size", "Infinite").unwrap();
        assert!(t.contains("world: (size: Infinite)"), "{t}");
    }

    #[test]
    fn adds_a_missing_field_to_its_struct() {
        let t = set(SRC, "until", "100.0").unwrap();
        assert!(t.starts_with("Scenario(until: 100.0, \n"), "{t}");
        let t = set(SRC, "robots[0].angle", "90.0").unwrap();
        assert!(t.contains("Group(angle: 90.0, count: 10"), "{t}");
    }

    #[test]
    fn refuses_paths_that_lead_nowhere() {
        assert_eq!(
            set(SRC, "robots[3].count", "1"),
            Err(EditError::Unknown("robots[3].count".into()))
        );
        assert_eq!(
            set(SRC, "robots[0].count.x", "1"),
            Err(EditError::NotAStruct("robots[0].count".into()))
        );
        assert!(set(SRC, "faults.at", "1").is_err());
    }
}
