//! The wafer-handling cell of wrc: stations and their teaching, the steps of `GET` and
//! `PUT`, wafer-mapping codes, the wafer map that survives crashes, and the simulated cell
//! that gives the simulated board its ground truth.
//!
//! Everything here is plain data and arithmetic — no threads, no sockets, no clocks. Files
//! are touched only by the load and save functions ([`Stations::load`],
//! [`Stations::save_atomic`], [`WaferMap::load`], [`WaferMap::save_atomic`]); saves are
//! atomic (temporary file, fsync, rename, directory fsync), so a crash at any moment leaves
//! the old file or the new one. No input makes anything panic: parsers and operations
//! return typed errors whose messages say what is wrong and what to do.
//!
//! * [`station`]: one station, its slot geometry (see its docs for the conventions) and the
//!   reachability check against a [`wrc_robot::Robot`].
//! * [`stations`]: the stations file (TOML), teaching, `STN` lines; [`DEMO_TOML`] is the demo
//!   cell shipped in `config/stations.toml`.
//! * [`transfer`]: the steps of a GET or PUT, as data.
//! * [`mapping`]: the slot codes of `MAP` (`0` absent, `1` present, `2` double, `X` cross).
//! * [`wafer_map`]: where every wafer is, two-phase transfers, start-up reconciliation, the
//!   file and the `WAFERS` line.
//! * [`journal`]: the transfer journal that tells, after a power loss, what an interrupted
//!   transfer did and which places became uncertain.
//! * [`world`]: the simulated cell (wafers, pick and place by the hand, the vacuum and
//!   mapping sensors) and [`Tracking`], which compares a wafer map with it.
//!
//! ```
//! use wrc_cell::{plan_get, SlotCode, Stations, Step, TransferKind, WaferMap, World};
//! use wrc_robot::Robot;
//!
//! let stations = Stations::embedded_demo();
//! stations.validate(&Robot::paper_default()).unwrap();
//!
//! // The simulated cell starts with 25 wafers in LP1; the controller maps the station.
//! let mut world = World::new(&stations);
//! let mut map = WaferMap::new(&stations);
//! let scan = world.map_station("LP1").unwrap();
//! assert_eq!(scan, vec![SlotCode::Present; 25]);
//! map.apply_mapping("LP1", &scan).unwrap();
//!
//! // GET LP1 3: begin (and save the map), run the steps, commit at CommitMap (and save).
//! let transfer = map.prepare(TransferKind::Get, "lp1", 3).unwrap();
//! map.begin(transfer).unwrap();
//! let (mut pose, mut vacuum) = (Default::default(), false);
//! for step in plan_get(stations.get("LP1").unwrap(), 3).unwrap() {
//!     match step {
//!         Step::Ptp(p, _) | Step::Line(p) | Step::Z(p) => pose = p,
//!         Step::Vacuum(on) => vacuum = on,
//!         Step::CheckVacuum { expect } => assert_eq!(world.vacuum_sensor(), expect),
//!         Step::CommitMap => { map.commit().unwrap(); }
//!         _ => {}
//!     }
//!     world.step(pose, vacuum);
//! }
//! assert_eq!(map.hand(), Some(transfer.wafer));
//! assert!(world.hand().is_some() && world.map_station("LP1").unwrap()[2] == SlotCode::Absent);
//! assert_eq!(map.wafers_line(), "hand=W3 LP1=W1,W2,-,W4..W25 LP2=?x25 AL=? PM1=? PM2=? BF1=?x5");
//! ```
#![deny(missing_docs)]

mod atomic;
pub mod blade;
pub mod journal;
pub mod mapping;
pub mod obstacle;
pub mod station;
pub mod stations;
pub mod transfer;
pub mod wafer_map;
pub mod world;

pub use atomic::write_atomic;
pub use blade::{Blade, MAX_BLADES};
pub use mapping::{parse_slot_codes, slot_codes_string, SlotCode, SlotCodesError};
pub use obstacle::{
    obstacle_line, CellModel, CellModelError, CellSettings, Contact, LineTolerance, Obstacle,
    ObstacleShape, SolidKind, StationVolume, Sweep, SweepContact, VolumeSpec,
};
pub use station::{
    parse_station_name, PoseKind, Station, StationError, StationKind, StationName, StationSim,
    INSIDE_BEYOND_SEAT_MM, INSIDE_ENTRY_MARGIN_MM, INSIDE_HALF_WIDTH_MM, MAX_INPUT, MAX_SLOTS,
};
pub use stations::{stn_line, Stations, StationsError, DEMO_NAME, DEMO_TOML};
pub use transfer::{plan, plan_get, plan_put, Step, TransferKind};
pub use wafer_map::{
    parse_slot_list, Interrupted, Location, MappingChanges, Reconciled, Sensed, SlotFault,
    SlotState, Transfer, WaferId, WaferMap, WaferMapError, END_LINE, FORMAT_VERSION,
};
pub use world::{
    Mismatch, SlotContent, Tracking, World, WorldError, WorldEvent, SEAT_TOLERANCE_DEG,
    SEAT_TOLERANCE_MM,
};
