//! The stations of a cell: an ordered list with unique names, read from and written to the
//! stations file (TOML, next to the configuration), written atomically, and taught.
//!
//! # The stations file
//!
//! ```toml
//! [[station]]
//! name = "LP1"                 # 1-16 of A-Z a-z 0-9 _ -, unique ignoring case
//! kind = "load_port"           # load_port | aligner | process_module | buffer
//! x_mm = 294.449               # taught pose of slot 1 (see the station module's geometry)
//! y_mm = -170.0
//! z_mm = 20.0                  # support height of slot 1
//! yaw_deg = -30.0              # hand direction into the station
//! slots = 25                   # 1-50; optional, default 1
//! pitch_mm = 10.0              # > 0 with several slots; optional, default 0
//! approach_mm = 220.0          # > 0
//! stroke_mm = 6.0              # > 0, < pitch_mm with several slots
//! speed_pct = 60.0             # 1-100
//! interlock_input = 14         # 0-31, optional: no interlock
//! posture = "right"            # "right" | "left", optional: either
//!
//! [station.sim]                # optional: the simulated board's initial wafers
//! wafers = "11111 11111 11111 11111 11111"   # one code per slot, slot 1 first
//!
//! [station.volume]             # optional: sizes of its solid box (crate::obstacle) [mm]
//! mouth_mm = 45.0              # each one optional: the default's
//! depth_mm = 235.0
//! width_mm = 310.0
//! bottom_mm = 10.0
//! top_mm = 280.0
//!
//! [[obstacle]]                 # optional: fixed obstacles, never entered
//! name = "column"              # as a station's name, and not one
//! kind = "cylinder"            # cylinder: x_mm, y_mm, radius_mm; box: x_mm, y_mm, yaw_deg
//! x_mm = -300.0                #   (optional, 0), depth_mm, width_mm
//! y_mm = 0.0
//! radius_mm = 40.0
//! bottom_mm = -400.0           # heights in the Z axis's frame
//! top_mm = 600.0
//!
//! [cell]                       # optional
//! travel_z_mm = 0.0            # where the folded arm travels clear of everything
//! clearance_mm = 2.0           # how close the controller lets the arm come to a solid
//! ```
//!
//! Unknown keys are refused; errors name the file, the line and the key.

use std::path::Path;

use serde::{Deserialize, Serialize};
use wrc_robot::{Pose, Posture, Robot};

use crate::atomic::write_atomic;
use crate::mapping::{parse_slot_codes, slot_codes_grouped};
use crate::obstacle::{
    CellModel, CellModelError, CellSettings, Obstacle, RawCell, RawObstacle, VolumeSpec,
};
use crate::station::{
    parse_station_name, same_name, Station, StationError, StationKind, StationSim,
};
use wrc_robot::Num;

/// The demo cell shipped with wrc (`config/stations.toml`): two 25-slot load ports LP1 and
/// LP2, an aligner AL and two process modules PM1 and PM2 around the paper's robot.
pub const DEMO_TOML: &str = include_str!("../../../config/stations.toml");

/// Name used for the embedded demo file in messages.
pub const DEMO_NAME: &str = "<embedded demo stations>";

/// A stations file or a station list that cannot be used.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum StationsError {
    /// The file could not be read.
    #[error("cannot read stations file {file}: {source}")]
    Read {
        /// The file.
        file: String,
        /// Why.
        source: std::io::Error,
    },
    /// The file could not be written.
    #[error("cannot write stations file {file}: {source}; the previous file is unchanged")]
    Write {
        /// The file.
        file: String,
        /// Why.
        source: std::io::Error,
    },
    /// Not valid TOML, an unknown key, or a value of the wrong type.
    #[error("stations file {file}: {message}")]
    Parse {
        /// The file.
        file: String,
        /// The TOML parser's message, with line, column and key.
        message: String,
    },
    /// A station in a file with an unusable value.
    #[error("stations file {file}{}: {source}", line_suffix(*line))]
    Station {
        /// The file.
        file: String,
        /// 1-based line of the station's `[[station]]` table, when known.
        line: Option<usize>,
        /// What is wrong.
        source: Box<StationError>,
    },
    /// A station with an unusable value, or one out of the robot's reach.
    #[error(transparent)]
    Invalid(Box<StationError>),
    /// Two stations with the same name (ignoring case).
    #[error("station name {name} is used twice (names are compared ignoring case); give every station its own name")]
    Duplicate {
        /// The name.
        name: String,
    },
    /// No station of that name.
    #[error("no station named {name:?}; the stations are: {known}")]
    NoSuchStation {
        /// The name asked for.
        name: String,
        /// The known names, comma-separated.
        known: String,
    },
}

impl From<StationError> for StationsError {
    fn from(e: StationError) -> Self {
        StationsError::Invalid(Box::new(e))
    }
}

fn line_suffix(line: Option<usize>) -> String {
    line.map(|l| format!(", line {l}")).unwrap_or_default()
}

/// An ordered list of checked stations with unique names (ignoring case), with the cell's
/// fixed obstacles and settings.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Stations {
    list: Vec<Station>,
    obstacles: Vec<Obstacle>,
    cell: CellSettings,
}

#[derive(Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawFile<S, O> {
    #[serde(default, skip_serializing_if = "Option::is_none")]
    cell: Option<RawCell>,
    #[serde(default = "Vec::new")]
    station: Vec<S>,
    #[serde(default = "Vec::new", skip_serializing_if = "Vec::is_empty")]
    obstacle: Vec<O>,
}

#[derive(Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawStation {
    name: String,
    kind: String,
    x_mm: f64,
    y_mm: f64,
    z_mm: f64,
    yaw_deg: f64,
    #[serde(default = "one")]
    slots: u16,
    #[serde(default)]
    pitch_mm: f64,
    approach_mm: f64,
    stroke_mm: f64,
    speed_pct: f64,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    interlock_input: Option<u8>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    posture: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    sim: Option<RawSim>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    volume: Option<VolumeSpec>,
}

#[derive(Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawSim {
    wafers: String,
}

fn one() -> u16 {
    1
}

fn posture_name(p: Posture) -> &'static str {
    match p {
        Posture::Right => "right",
        Posture::Left => "left",
    }
}

impl RawStation {
    fn into_station(self) -> Result<Station, StationError> {
        let name = parse_station_name(&self.name)?;
        let bad = |field: &'static str, reason: String| StationError::Invalid {
            station: name,
            field,
            reason,
        };
        let kind = StationKind::parse(&self.kind).ok_or_else(|| {
            bad(
                "kind",
                format!(
                    "{:?} is not a station kind; expected load_port, aligner, process_module or buffer",
                    self.kind
                ),
            )
        })?;
        let posture = match self.posture.as_deref() {
            None => None,
            Some("right") => Some(Posture::Right),
            Some("left") => Some(Posture::Left),
            Some(other) => {
                return Err(bad(
                    "posture",
                    format!("{other:?} is not a posture; expected \"right\" or \"left\" (or leave it out for either)"),
                ))
            }
        };
        let sim = match self.sim {
            None => None,
            Some(raw) => Some(StationSim {
                wafers: parse_slot_codes(&raw.wafers)
                    .map_err(|e| bad("sim.wafers", e.to_string()))?,
            }),
        };
        let station = Station {
            name,
            kind,
            pose: Pose {
                x: self.x_mm,
                y: self.y_mm,
                z: self.z_mm,
                yaw: self.yaw_deg,
            },
            slots: self.slots,
            pitch_mm: self.pitch_mm,
            approach_mm: self.approach_mm,
            stroke_mm: self.stroke_mm,
            speed_pct: self.speed_pct,
            interlock_input: self.interlock_input,
            posture,
            sim,
            volume: self.volume.unwrap_or_default(),
        };
        station.check()?;
        Ok(station)
    }

    fn from_station(s: &Station) -> RawStation {
        RawStation {
            name: s.name.to_string(),
            kind: s.kind.as_str().into(),
            x_mm: s.pose.x,
            y_mm: s.pose.y,
            z_mm: s.pose.z,
            yaw_deg: s.pose.yaw,
            slots: s.slots,
            pitch_mm: s.pitch_mm,
            approach_mm: s.approach_mm,
            stroke_mm: s.stroke_mm,
            speed_pct: s.speed_pct,
            interlock_input: s.interlock_input,
            posture: s.posture.map(|p| posture_name(p).into()),
            sim: s.sim.as_ref().map(|sim| RawSim {
                wafers: slot_codes_grouped(&sim.wafers),
            }),
            volume: (!s.volume.is_empty()).then_some(s.volume),
        }
    }
}

/// 1-based line of byte offset `at` in `text`.
fn line_of(text: &str, at: usize) -> usize {
    let at = at.min(text.len());
    text.as_bytes()[..at]
        .iter()
        .filter(|&&b| b == b'\n')
        .count()
        + 1
}

impl Stations {
    /// No stations.
    pub fn new() -> Stations {
        Stations::default()
    }

    /// The demo cell ([`DEMO_TOML`]).
    pub fn embedded_demo() -> Stations {
        // The embedded file is checked by a unit test, so this cannot fail in a release.
        Stations::parse(DEMO_TOML, DEMO_NAME).expect("the embedded demo stations are valid")
    }

    /// Stations from a list, checking each one and the names' uniqueness.
    pub fn from_list(list: Vec<Station>) -> Result<Stations, StationsError> {
        let mut stations = Stations::new();
        for s in list {
            stations.push(s)?;
        }
        Ok(stations)
    }

    /// Add a station at the end, after checking it ([`Station::check`]) and its name.
    pub fn push(&mut self, station: Station) -> Result<(), StationsError> {
        station.check()?;
        if self.get(station.name.as_str()).is_some() {
            return Err(StationsError::Duplicate {
                name: station.name.to_string(),
            });
        }
        self.list.push(station);
        Ok(())
    }

    /// Parse stations-file text; `file` names it in errors. Each station is checked on its
    /// own ([`Station::check`]); whether the robot reaches it is [`Stations::validate`].
    pub fn parse(text: &str, file: &str) -> Result<Stations, StationsError> {
        let raw: RawFile<toml::Spanned<RawStation>, toml::Spanned<RawObstacle>> =
            toml::from_str(text).map_err(|e| StationsError::Parse {
                file: file.to_string(),
                message: e.to_string().trim_end().replace('\n', "\n  "),
            })?;
        let mut stations = Stations::new();
        if let Some(cell) = raw.cell {
            let defaults = CellSettings::default();
            stations.cell = CellSettings {
                travel_z_mm: cell.travel_z_mm,
                clearance_mm: cell.clearance_mm.unwrap_or(defaults.clearance_mm),
            };
            stations
                .cell
                .check()
                .map_err(|message| StationsError::Parse {
                    file: file.to_string(),
                    message,
                })?;
        }
        for spanned in raw.station {
            let line = Some(line_of(text, spanned.span().start));
            let at = |source: StationError| StationsError::Station {
                file: file.to_string(),
                line,
                source: Box::new(source),
            };
            let station = spanned.into_inner().into_station().map_err(at)?;
            if stations.get(station.name.as_str()).is_some() {
                return Err(at(StationError::Invalid {
                    station: station.name,
                    field: "name",
                    reason: "is used by an earlier station too (names are compared ignoring case); give every station its own name".into(),
                }));
            }
            stations.list.push(station);
        }
        for spanned in raw.obstacle {
            let line = Some(line_of(text, spanned.span().start));
            let at = |source: StationError| StationsError::Station {
                file: file.to_string(),
                line,
                source: Box::new(source),
            };
            let obstacle = spanned.into_inner().into_obstacle().map_err(at)?;
            if stations.get(obstacle.name.as_str()).is_some()
                || stations.obstacle(obstacle.name.as_str()).is_some()
            {
                return Err(at(StationError::Invalid {
                    station: obstacle.name,
                    field: "name",
                    reason: "is used by a station or an earlier obstacle too (names are compared ignoring case); give every obstacle its own name".into(),
                }));
            }
            stations.obstacles.push(obstacle);
        }
        Ok(stations)
    }

    /// Read and parse the stations file at `path`.
    pub fn load(path: &Path) -> Result<Stations, StationsError> {
        let file = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|source| StationsError::Read {
            file: file.clone(),
            source,
        })?;
        Stations::parse(&text, &file)
    }

    /// Check every station against `robot` ([`Station::validate`]).
    pub fn validate(&self, robot: &Robot) -> Result<(), StationsError> {
        for s in &self.list {
            s.validate(robot)?;
        }
        Ok(())
    }

    /// The stations as stations-file text (parses back to an equal list).
    pub fn to_toml(&self) -> String {
        let cell = (self.cell != CellSettings::default()).then_some(RawCell {
            travel_z_mm: self.cell.travel_z_mm,
            clearance_mm: Some(self.cell.clearance_mm),
        });
        let raw = RawFile {
            cell,
            station: self.list.iter().map(RawStation::from_station).collect(),
            obstacle: self
                .obstacles
                .iter()
                .map(RawObstacle::from_obstacle)
                .collect(),
        };
        let body = toml::to_string(&raw).unwrap_or_else(|e| {
            // Serializing plain strings and finite numbers cannot fail; keep the file
            // readable all the same.
            format!("# could not write the stations: {e}\n")
        });
        format!(
            "# wrc stations: taught poses and geometry of every station (format: the wrc-cell \
             crate's stations module).\n# Written by TEACH; safe to edit while the controller \
             is stopped.\n\n{body}"
        )
    }

    /// Write [`Stations::to_toml`] to `path` atomically: `path.tmp` in the same directory,
    /// fsync, rename over `path`, fsync the directory. A crash leaves the old or the new file.
    pub fn save_atomic(&self, path: &Path) -> Result<(), StationsError> {
        write_atomic(path, self.to_toml().as_bytes()).map_err(|source| StationsError::Write {
            file: path.display().to_string(),
            source,
        })
    }

    /// The cell's fixed obstacles, in file order.
    pub fn obstacles(&self) -> &[Obstacle] {
        &self.obstacles
    }

    /// The obstacle called `name`, ignoring case.
    pub fn obstacle(&self, name: &str) -> Option<&Obstacle> {
        self.obstacles
            .iter()
            .find(|o| same_name(o.name.as_str(), name))
    }

    /// The same cell with these obstacles (checked; names unique among stations and
    /// obstacles).
    pub fn with_obstacles(mut self, obstacles: Vec<Obstacle>) -> Result<Stations, StationsError> {
        self.obstacles.clear();
        for o in obstacles {
            o.check()?;
            if self.get(o.name.as_str()).is_some() || self.obstacle(o.name.as_str()).is_some() {
                return Err(StationsError::Duplicate {
                    name: o.name.to_string(),
                });
            }
            self.obstacles.push(o);
        }
        Ok(self)
    }

    /// The cell's settings (`[cell]`).
    pub fn cell(&self) -> &CellSettings {
        &self.cell
    }

    /// The same cell with `settings`.
    pub fn with_cell(mut self, settings: CellSettings) -> Stations {
        self.cell = settings;
        self
    }

    /// The cell as solids for `robot`'s collision checks ([`CellModel`]).
    pub fn model(&self, robot: &Robot) -> Result<CellModel, CellModelError> {
        CellModel::new(robot, &self.list, &self.obstacles, self.cell)
    }

    /// The station called `name`, ignoring case.
    pub fn get(&self, name: &str) -> Option<&Station> {
        self.list.iter().find(|s| same_name(s.name.as_str(), name))
    }

    /// Position of the station called `name` (ignoring case) in the list.
    pub fn index_of(&self, name: &str) -> Option<usize> {
        self.list
            .iter()
            .position(|s| same_name(s.name.as_str(), name))
    }

    /// The station called `name`, or an error listing the known names.
    pub fn require(&self, name: &str) -> Result<&Station, StationsError> {
        self.get(name).ok_or_else(|| self.no_such(name))
    }

    fn no_such(&self, name: &str) -> StationsError {
        let known = if self.list.is_empty() {
            "(none)".to_string()
        } else {
            self.list
                .iter()
                .map(|s| s.name.as_str())
                .collect::<Vec<_>>()
                .join(", ")
        };
        StationsError::NoSuchStation {
            name: name.chars().take(40).collect(),
            known,
        }
    }

    /// Teach: give the existing station `name` the taught pose `pose` (the current TCP pose,
    /// with the hand at slot 1's support height; yaw is wrapped into (-180, 180]). The
    /// station must still pass [`Station::validate`] against `robot` with its new pose;
    /// otherwise nothing changes.
    ///
    /// `TEACH` does not create stations: slot count, pitch, stroke and approach cannot be
    /// guessed safely, so a new station is added to the stations file with its geometry first
    /// and then taught.
    pub fn teach(
        &mut self,
        name: &str,
        pose: Pose,
        robot: &Robot,
    ) -> Result<&Station, StationsError> {
        let i = self.index_of(name).ok_or_else(|| self.no_such(name))?;
        let taught = self.list[i].with_pose(pose);
        taught.validate(robot)?;
        self.list[i] = taught;
        Ok(&self.list[i])
    }

    /// The stations in order.
    pub fn iter(&self) -> std::slice::Iter<'_, Station> {
        self.list.iter()
    }

    /// The stations in order, as a slice.
    pub fn as_slice(&self) -> &[Station] {
        &self.list
    }

    /// Number of stations.
    pub fn len(&self) -> usize {
        self.list.len()
    }

    /// Whether there are no stations.
    pub fn is_empty(&self) -> bool {
        self.list.is_empty()
    }
}

impl<'a> IntoIterator for &'a Stations {
    type Item = &'a Station;
    type IntoIter = std::slice::Iter<'a, Station>;
    fn into_iter(self) -> Self::IntoIter {
        self.list.iter()
    }
}

/// The body of one `STN` reply line for `station`, its volume for wafers of
/// `wafer_radius_mm`: `LP1 kind=load_port x=294.449 y=-170 z=20 yaw=-30 slots=25 pitch=10
/// approach=220 stroke=6 speed=30 interlock=14 posture=any mouth=45 depth=235 width=310
/// bottom=10 top=280 opening=152` (one line; numbers in \[mm\], \[deg\] and [%] with at most 3
/// decimals and no trailing zeros; `interlock=none` without an interlock; `posture` is
/// `right`, `left` or `any`; `mouth` … `top` the solid box ([`crate::StationVolume`]),
/// `opening` the half width of the hand's wafer on its line with the simulated cell's
/// tolerance, what passes the box's front).
pub fn stn_line(station: &Station, wafer_radius_mm: f64) -> String {
    let v = station.volume(wafer_radius_mm);
    let interlock = station
        .interlock_input
        .map_or_else(|| "none".to_string(), |i| i.to_string());
    let posture = station.posture.map_or("any", posture_name);
    format!(
        "{} kind={} x={} y={} z={} yaw={} slots={} pitch={} approach={} stroke={} speed={} interlock={} posture={} mouth={} depth={} width={} bottom={} top={} opening={}",
        station.name,
        station.kind,
        Num(station.pose.x),
        Num(station.pose.y),
        Num(station.pose.z),
        Num(station.pose.yaw),
        station.slots,
        Num(station.pitch_mm),
        Num(station.approach_mm),
        Num(station.stroke_mm),
        Num(station.speed_pct),
        interlock,
        posture,
        Num(v.mouth_mm),
        Num(v.depth_mm),
        Num(v.width_mm),
        Num(v.bottom_mm),
        Num(v.top_mm),
        Num(wafer_radius_mm + crate::obstacle::LineTolerance::WORLD.lateral_mm),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mapping::SlotCode;

    #[test]
    fn the_demo_cell_parses_and_every_slot_is_reachable() {
        let stations = Stations::embedded_demo();
        let names: Vec<&str> = stations.iter().map(|s| s.name.as_str()).collect();
        assert_eq!(names, ["LP1", "LP2", "AL", "PM1", "PM2", "BF1"]);
        let robot = Robot::paper_default();
        stations.validate(&robot).unwrap();

        let lp1 = stations.get("lp1").unwrap();
        assert_eq!(
            (lp1.kind, lp1.slots, lp1.pitch_mm),
            (StationKind::LoadPort, 25, 10.0)
        );
        assert_eq!(lp1.interlock_input, Some(14));
        assert_eq!(
            lp1.sim.as_ref().unwrap().wafers,
            vec![SlotCode::Present; 25]
        );
        let lp2 = stations.get("LP2").unwrap();
        assert_eq!((lp2.slots, lp2.interlock_input), (25, Some(14)));
        assert_eq!(lp2.sim.as_ref().unwrap().wafers, vec![SlotCode::Absent; 25]);
        for name in ["AL", "PM1", "PM2"] {
            let s = stations.get(name).unwrap();
            assert_eq!(s.slots, 1, "{name}");
            assert_eq!(s.sim.as_ref().unwrap().wafers, [SlotCode::Absent], "{name}");
        }
        assert_eq!(stations.get("AL").unwrap().kind, StationKind::Aligner);
        assert_eq!(
            stations.get("PM2").unwrap().kind,
            StationKind::ProcessModule
        );
        let bf1 = stations.get("BF1").unwrap();
        assert_eq!((bf1.kind, bf1.slots), (StationKind::Buffer, 5));
        assert_eq!(bf1.sim.as_ref().unwrap().wafers, vec![SlotCode::Absent; 5]);
        // BF1 faces -145 deg, where only the left elbow takes the line in without passing
        // the shoulder's -180 deg: its transfers use it, from the home posture (right) too.
        let q = bf1
            .approach_joints(&robot, 1, false, &robot.home())
            .unwrap();
        assert_eq!(Posture::of(&robot, &q), Some(Posture::Left));
        assert!(Station {
            posture: Some(Posture::Right),
            ..bf1.clone()
        }
        .validate(&robot)
        .is_err());
        // Neighbouring wafer centres at least 320 mm apart, as the file says.
        let all: Vec<&Station> = stations.iter().collect();
        for (i, a) in all.iter().enumerate() {
            for b in &all[i + 1..] {
                let d = (a.pose.x - b.pose.x).hypot(a.pose.y - b.pose.y);
                assert!(d >= 320.0, "{} and {} are {d} mm apart", a.name, b.name);
            }
        }

        // The margins promised in the file's comments: seated poses within 360 mm of the
        // base, approach poses at least 60 mm from it, the top slot lifted within the Z lift.
        for s in &stations {
            for slot in 1..=s.slots {
                for lifted in [false, true] {
                    let seated = s.seated_pose(slot, lifted).unwrap();
                    let approach = s.approach_pose(slot, lifted).unwrap();
                    assert!(seated.x.hypot(seated.y) <= 360.0, "{}", s.name);
                    assert!(approach.x.hypot(approach.y) >= 60.0, "{}", s.name);
                    assert!((0.0..=300.0).contains(&seated.z), "{} {slot}", s.name);
                }
            }
        }
    }

    #[test]
    fn to_toml_parses_back_to_the_same_stations() {
        let mut stations = Stations::embedded_demo();
        stations.list[2].posture = Some(Posture::Left);
        stations.list[3].sim = None;
        stations.list[0].sim.as_mut().unwrap().wafers[3] = SlotCode::Cross;
        let text = stations.to_toml();
        let back = Stations::parse(&text, "out.toml").unwrap();
        assert_eq!(back, stations);
        assert!(
            text.contains("[[station]]") && text.contains("[station.sim]"),
            "{text}"
        );
        assert!(text.contains("wafers = \"111X1 11111"), "{text}");
    }

    #[test]
    fn save_atomic_replaces_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("stations.toml");
        let stations = Stations::embedded_demo();
        stations.save_atomic(&path).unwrap();
        assert_eq!(Stations::load(&path).unwrap(), stations);
        let mut fewer = stations.clone();
        fewer.list.truncate(1);
        fewer.save_atomic(&path).unwrap();
        assert_eq!(Stations::load(&path).unwrap(), fewer);
        assert!(!dir.path().join("stations.toml.tmp").exists());
        let e = stations
            .save_atomic(&dir.path().join("missing/stations.toml"))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("cannot write stations file") && e.contains("missing"),
            "{e}"
        );
    }

    fn err(text: &str) -> String {
        Stations::parse(text, "cell.toml").unwrap_err().to_string()
    }

    const ONE: &str = r#"
[[station]]
name = "PM1"
kind = "process_module"
x_mm = -340.0
y_mm = 0.0
z_mm = 100.0
yaw_deg = 180.0
approach_mm = 220.0
stroke_mm = 10.0
speed_pct = 40.0
"#;

    fn with(from: &str, to: &str) -> String {
        assert!(ONE.contains(from), "{from}");
        ONE.replacen(from, to, 1)
    }

    #[test]
    fn defaults_apply_to_optional_keys() {
        let s = Stations::parse(ONE, "cell.toml").unwrap();
        let pm = s.get("pm1").unwrap();
        assert_eq!((pm.slots, pm.pitch_mm, pm.interlock_input), (1, 0.0, None));
        assert_eq!((pm.posture, pm.sim.is_none()), (None, true));
        assert!(Stations::parse("", "empty.toml").unwrap().is_empty());
    }

    #[test]
    fn bad_files_are_refused_with_file_line_and_key() {
        let e = err(&with("speed_pct = 40.0", "speed_pct = 40.0\nspeed = 3"));
        assert!(
            e.contains("cell.toml") && e.contains("speed") && e.contains("line 12"),
            "{e}"
        );
        assert!(e.contains("unknown field"), "{e}");

        let e = err(&with("approach_mm = 220.0\n", ""));
        assert!(e.contains("approach_mm") && e.contains("missing"), "{e}");

        let e = err(&with("x_mm = -340.0", "x_mm = \"far\""));
        assert!(e.contains("line 5") && e.contains("x_mm"), "{e}");

        let e = err(&with("speed_pct = 40.0", "speed_pct = 40.0\nslots = -1"));
        assert!(e.contains("slots") && e.contains("line 12"), "{e}");

        let e = err(&with("speed_pct = 40.0", "speed_pct = 0.0"));
        assert!(
            e.contains("cell.toml, line 2")
                && e.contains("station PM1: speed_pct must be 1 to 100"),
            "{e}"
        );

        let e = err(&with("\"process_module\"", "\"oven\""));
        assert!(
            e.contains("kind") && e.contains("\"oven\"") && e.contains("load_port"),
            "{e}"
        );

        let e = err(&with("name = \"PM1\"", "name = \"PM 1\""));
        assert!(e.contains("\"PM 1\" is not a usable station name"), "{e}");

        let e = err(&with(
            "speed_pct = 40.0",
            "speed_pct = 40.0\nposture = \"up\"",
        ));
        assert!(e.contains("posture") && e.contains("\"up\""), "{e}");

        let e = err(&with(
            "speed_pct = 40.0",
            "speed_pct = 40.0\ninterlock_input = 40",
        ));
        assert!(
            e.contains("interlock_input must be an input number 0 to 31"),
            "{e}"
        );

        let e = err(&with(
            "speed_pct = 40.0",
            "speed_pct = 40.0\ninterlock_input = 400",
        ));
        assert!(e.contains("interlock_input"), "{e}");

        let e = err(&with(
            "speed_pct = 40.0",
            "speed_pct = 40.0\n[station.sim]\nwafers = \"1\"\nextra = 1",
        ));
        assert!(e.contains("extra"), "{e}");

        let e = err(&with(
            "speed_pct = 40.0",
            "speed_pct = 40.0\n[station.sim]\nwafers = \"3\"",
        ));
        assert!(e.contains("sim.wafers") && e.contains("'3'"), "{e}");

        let e = err(&with(
            "speed_pct = 40.0",
            "speed_pct = 40.0\n[station.sim]\nwafers = \"11\"",
        ));
        assert!(e.contains("2 codes for 1 slots"), "{e}");

        let e = err(&format!("{ONE}\n{}", ONE.replace("PM1", "pm1")));
        assert!(
            e.contains("line 14") && e.contains("pm1") && e.contains("used by an earlier station"),
            "{e}"
        );

        let e = err("stations = 3");
        assert!(e.contains("cell.toml") && e.contains("stations"), "{e}");

        let e = err("[[station]\nname=");
        assert!(e.contains("cell.toml") && e.contains("line 1"), "{e}");
    }

    #[test]
    fn a_missing_file_is_named() {
        let e = Stations::load(Path::new("/nonexistent/stations.toml"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("/nonexistent/stations.toml"), "{e}");
    }

    #[test]
    fn push_refuses_duplicates_and_bad_stations() {
        let mut stations = Stations::parse(ONE, "cell.toml").unwrap();
        let mut copy = stations.get("PM1").unwrap().clone();
        copy.name = crate::parse_station_name("pm1").unwrap();
        let e = stations.push(copy.clone()).unwrap_err();
        assert!(matches!(e, StationsError::Duplicate { .. }), "{e}");
        copy.name = crate::parse_station_name("PM9").unwrap();
        copy.stroke_mm = 0.0;
        assert!(stations
            .push(copy.clone())
            .unwrap_err()
            .to_string()
            .contains("stroke_mm"));
        copy.stroke_mm = 5.0;
        stations.push(copy).unwrap();
        assert_eq!(stations.len(), 2);
        assert_eq!(
            Stations::from_list(stations.as_slice().to_vec()).unwrap(),
            stations
        );
    }

    #[test]
    fn teach_sets_the_pose_of_an_existing_station_only() {
        let robot = Robot::paper_default();
        let mut stations = Stations::embedded_demo();
        let pose = Pose {
            x: -330.0,
            y: 10.0,
            z: 95.0,
            yaw: -181.0,
        };
        let taught = stations.teach("pm1", pose, &robot).unwrap();
        assert_eq!(taught.pose, Pose { yaw: 179.0, ..pose });
        assert_eq!(stations.get("PM1").unwrap().pose.yaw, 179.0);

        let e = stations.teach("PM7", pose, &robot).unwrap_err();
        assert!(matches!(e, StationsError::NoSuchStation { .. }));
        let msg = e.to_string();
        assert!(
            msg.contains("\"PM7\"") && msg.contains("LP1, LP2, AL, PM1, PM2"),
            "{msg}"
        );

        // Out of reach: refused, the old pose kept.
        let before = stations.clone();
        let far = Pose {
            x: 398.5,
            y: 0.0,
            z: 20.0,
            yaw: 0.0,
        };
        let e = stations.teach("LP1", far, &robot).unwrap_err().to_string();
        assert!(e.contains("station LP1"), "{e}");
        assert_eq!(stations, before);
        let nan = Pose { x: f64::NAN, ..far };
        assert!(stations.teach("LP1", nan, &robot).is_err());
        assert_eq!(stations, before);
    }

    #[test]
    fn stn_lines_are_compact() {
        let stations = Stations::embedded_demo();
        let line = stn_line(stations.get("LP1").unwrap(), 150.0);
        assert_eq!(
            line,
            "LP1 kind=load_port x=294.449 y=-170 z=20 yaw=-30 slots=25 pitch=10 approach=220 \
             stroke=6 speed=60 interlock=14 posture=any mouth=45 depth=235 width=310 bottom=10 \
             top=280 opening=152"
        );
        let line = stn_line(stations.get("PM1").unwrap(), 150.0);
        assert!(
            line.starts_with("PM1 kind=process_module x=-308.145 y=143.69 "),
            "{line}"
        );
        // One slot: 40 mm tall from 10 mm below its support.
        assert!(
            line.ends_with(" interlock=none posture=any mouth=45 depth=235 width=310 bottom=90 top=130 opening=152"),
            "{line}"
        );
        // The aligner's approach pose is nearer (200 mm): its box begins nearer the seat.
        let line = stn_line(stations.get("AL").unwrap(), 150.0);
        assert!(line.contains(" mouth=25 depth=215 "), "{line}");
    }

    #[test]
    fn lookup_ignores_case() {
        let stations = Stations::embedded_demo();
        assert_eq!(stations.index_of("pm2"), Some(4));
        assert!(stations.get("Lp2").is_some());
        assert!(stations.get("LP3").is_none());
        assert!(stations.require("nope").is_err());
    }
}
