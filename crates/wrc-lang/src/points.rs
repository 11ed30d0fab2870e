//! Named points: the poses (and joint positions) a program refers to by name, kept in a
//! points file next to the program (`<program>.points.toml`). The compiler reads it (a
//! point is a global of the program whose value it knows, so reach and limit checks apply);
//! `TEACH name` in the program, the host's `POINT` verb and the GUI write it.
//!
//! ```toml
//! # The named points of program demo: x, y, z [mm], yaw [deg]; joints in axis units.
//! [points]
//! PARK = { joints = [-75, 150, -75, 0] }
//! SAFE = { x = 250, y = 0, z = 20, yaw = 0 }
//! ```

use std::collections::BTreeMap;
use std::fmt::Write as _;

use wrc_robot::{Joints, Num, Pose, MAX_AXES};

/// Longest point name [characters].
pub const POINT_NAME_LEN: usize = 32;

/// Most points in one file.
pub const MAX_POINTS: usize = 1000;

/// A named point's value.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum PointValue {
    /// A pose of the tool centre point: x, y, z [mm], yaw [deg].
    Pose(Pose),
    /// Joint positions, one per axis [deg or mm]; entries past the robot's axes are 0.
    Joints(Joints),
}

/// A points file that cannot be read, or a point that cannot be stored.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum PointsError {
    /// The text is not TOML, or not a `[points]` table.
    #[error("the points file is not valid: {0}")]
    Syntax(String),
    /// A name that cannot name a point.
    #[error("{0:?} cannot name a point: a point's name is 1 to 32 letters, digits or '_', starting with a letter or '_', and not a keyword of the language")]
    BadName(String),
    /// The same name twice (names are case-insensitive).
    #[error("point {0} is in the points file twice (names are case-insensitive)")]
    Duplicate(String),
    /// A point that is neither `{ x, y, z, yaw }` nor `{ joints = [...] }`, or holds a value
    /// that is not a finite number.
    #[error("point {name}: {reason}")]
    BadValue {
        /// The point.
        name: String,
        /// What is wrong.
        reason: String,
    },
    /// More than [`MAX_POINTS`].
    #[error("a points file holds at most {MAX_POINTS} points")]
    TooMany,
}

/// The named points of one program, sorted by name.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Points {
    points: BTreeMap<String, (String, PointValue)>,
}

/// The points file of program `name`: `<name>.points.toml`.
pub fn points_file_name(program: &str) -> String {
    format!("{program}.points.toml")
}

/// Whether `name` can name a point.
pub fn point_name_ok(name: &str) -> bool {
    let mut chars = name.chars();
    let first_ok = chars
        .next()
        .is_some_and(|c| c.is_ascii_alphabetic() || c == '_');
    first_ok
        && name.len() <= POINT_NAME_LEN
        && name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_')
        && !crate::statements::is_reserved(&name.to_ascii_uppercase())
}

impl Points {
    /// No points.
    pub fn new() -> Points {
        Points::default()
    }

    /// Read a points file for a robot with `axes` axes.
    pub fn parse(text: &str, axes: usize) -> Result<Points, PointsError> {
        let table: toml::Table =
            toml::from_str(text).map_err(|e| PointsError::Syntax(e.message().to_string()))?;
        let mut out = Points::new();
        for (key, value) in &table {
            if key != "points" {
                return Err(PointsError::Syntax(format!(
                    "unknown table [{key}]; the file holds one table, [points]"
                )));
            }
            let Some(points) = value.as_table() else {
                return Err(PointsError::Syntax("points must be a table".into()));
            };
            for (name, spec) in points {
                let v = point_value(name, spec, axes)?;
                if out.points.contains_key(&name.to_ascii_uppercase()) {
                    return Err(PointsError::Duplicate(name.clone()));
                }
                out.set(name, v)?;
            }
        }
        Ok(out)
    }

    /// The file's text: a comment naming the program, then `[points]`, one line a point.
    pub fn to_text(&self, program: &str, axes: usize) -> String {
        let mut out = format!(
            "# The named points of program {program}: x, y, z [mm], yaw [deg]; joints in axis units.\n# TEACH in the program, POINT on the host protocol and the GUI's Points panel write it.\n[points]\n"
        );
        for (name, value) in self.iter() {
            let _ = match value {
                PointValue::Pose(p) => writeln!(
                    out,
                    "{name} = {{ x = {}, y = {}, z = {}, yaw = {} }}",
                    toml_num(p.x),
                    toml_num(p.y),
                    toml_num(p.z),
                    toml_num(p.yaw)
                ),
                PointValue::Joints(j) => writeln!(
                    out,
                    "{name} = {{ joints = [{}] }}",
                    j[..axes.min(MAX_AXES)]
                        .iter()
                        .map(|v| toml_num(*v))
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
            };
        }
        out
    }

    /// The points, sorted by name: each name as written and its value.
    pub fn iter(&self) -> impl Iterator<Item = (&str, &PointValue)> {
        self.points.values().map(|(n, v)| (n.as_str(), v))
    }

    /// Number of points.
    pub fn len(&self) -> usize {
        self.points.len()
    }

    /// `true` when there are none.
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    /// The point `name` (case-insensitive).
    pub fn get(&self, name: &str) -> Option<&PointValue> {
        self.points.get(&name.to_ascii_uppercase()).map(|(_, v)| v)
    }

    /// Store `value` as point `name` (a new one, or in place of the old value, keeping the
    /// name as first written).
    pub fn set(&mut self, name: &str, value: PointValue) -> Result<(), PointsError> {
        if !point_name_ok(name) {
            return Err(PointsError::BadName(name.to_string()));
        }
        check_finite(name, &value)?;
        let key = name.to_ascii_uppercase();
        if !self.points.contains_key(&key) && self.points.len() >= MAX_POINTS {
            return Err(PointsError::TooMany);
        }
        let shown = self
            .points
            .get(&key)
            .map_or_else(|| name.to_string(), |(n, _)| n.clone());
        self.points.insert(key, (shown, value));
        Ok(())
    }

    /// Remove point `name`; whether it was there.
    pub fn remove(&mut self, name: &str) -> bool {
        self.points.remove(&name.to_ascii_uppercase()).is_some()
    }
}

/// A number as the file writes it: up to 3 decimals (1 µm, 0.001°: the protocol's
/// resolution), no trailing zeros, always with a point (a TOML float).
fn toml_num(x: f64) -> String {
    let s = Num(x).to_string();
    if s.contains('.') || s.contains('e') || s.contains("inf") || s.contains("nan") {
        s
    } else {
        format!("{s}.0")
    }
}

fn check_finite(name: &str, value: &PointValue) -> Result<(), PointsError> {
    let finite = match value {
        PointValue::Pose(p) => [p.x, p.y, p.z, p.yaw].iter().all(|v| v.is_finite()),
        PointValue::Joints(j) => j.iter().all(|v| v.is_finite()),
    };
    if finite {
        Ok(())
    } else {
        Err(PointsError::BadValue {
            name: name.to_string(),
            reason: "every value must be a finite number".into(),
        })
    }
}

fn point_value(name: &str, spec: &toml::Value, axes: usize) -> Result<PointValue, PointsError> {
    let bad = |reason: String| PointsError::BadValue {
        name: name.to_string(),
        reason,
    };
    let Some(t) = spec.as_table() else {
        return Err(bad(
            "expected { x = …, y = …, z = …, yaw = … } or { joints = [ … ] }".into(),
        ));
    };
    let num = |v: &toml::Value| -> Option<f64> {
        v.as_float().or_else(|| v.as_integer().map(|i| i as f64))
    };
    if let Some(list) = t.get("joints") {
        if t.len() != 1 {
            return Err(bad("a joints point holds only joints = [ … ]".into()));
        }
        let Some(list) = list.as_array() else {
            return Err(bad("joints must be a list of numbers".into()));
        };
        if list.len() != axes {
            return Err(bad(format!(
                "joints has {} values; the robot has {axes} axes",
                list.len()
            )));
        }
        let mut j = [0.0; MAX_AXES];
        for (slot, v) in j.iter_mut().zip(list) {
            *slot = num(v).ok_or_else(|| bad("joints must be numbers".into()))?;
        }
        let value = PointValue::Joints(j);
        check_finite(name, &value)?;
        return Ok(value);
    }
    let mut fields = [0.0; 4];
    for (slot, key) in fields.iter_mut().zip(["x", "y", "z", "yaw"]) {
        let v = t
            .get(key)
            .ok_or_else(|| bad(format!("{key} is missing (a pose has x, y, z and yaw)")))?;
        *slot = num(v).ok_or_else(|| bad(format!("{key} must be a number")))?;
    }
    if let Some(extra) = t
        .keys()
        .find(|k| !["x", "y", "z", "yaw"].contains(&k.as_str()))
    {
        return Err(bad(format!(
            "unknown key {extra} (a pose has x, y, z and yaw)"
        )));
    }
    let value = PointValue::Pose(Pose {
        x: fields[0],
        y: fields[1],
        z: fields[2],
        yaw: fields[3],
    });
    check_finite(name, &value)?;
    Ok(value)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_points_file_round_trips() {
        let mut p = Points::new();
        p.set(
            "Safe",
            PointValue::Pose(Pose {
                x: 250.0,
                y: -0.1234567,
                z: 20.0,
                yaw: 90.0,
            }),
        )
        .unwrap();
        let mut j = [0.0; MAX_AXES];
        j[..4].copy_from_slice(&[-75.0, 150.0, -75.0, 0.5]); // exact in 3 decimals
        p.set("PARK", PointValue::Joints(j)).unwrap();
        let text = p.to_text("demo", 4);
        let back = Points::parse(&text, 4).unwrap();
        assert_eq!(back.len(), 2);
        assert_eq!(back.get("park"), Some(&PointValue::Joints(j)));
        match back.get("SAFE") {
            Some(PointValue::Pose(q)) => assert_eq!(q.y, -0.123, "{q:?}"),
            other => panic!("{other:?}"),
        }
        assert_eq!(
            back.iter().map(|(n, _)| n).collect::<Vec<_>>(),
            ["PARK", "Safe"]
        );
    }

    #[test]
    fn bad_files_say_what_is_wrong() {
        let cases = [
            ("[points]\nA = { x = 1, y = 2, z = 3 }\n", "yaw is missing"),
            ("[points]\nA = { joints = [1, 2] }\n", "the robot has 4 axes"),
            ("[points]\nIF = { x = 1, y = 2, z = 3, yaw = 4 }\n", "cannot name a point"),
            ("[points]\nA = { x = 1, y = 2, z = 3, yaw = 4 }\na = { x = 1, y = 2, z = 3, yaw = 4 }\n", "twice"),
            ("[other]\n", "unknown table"),
            ("[points\n", "not valid"),
            ("[points]\nA = { x = 1, y = 2, z = 3, yaw = 4, q = 1 }\n", "unknown key q"),
        ];
        for (text, want) in cases {
            let e = Points::parse(text, 4).unwrap_err().to_string();
            assert!(e.contains(want), "{text:?}: {e}");
        }
    }
}
