//! The robot model of wrc: a planar wafer-transfer arm (shoulder, elbow, optional hand
//! joint and Z lift) with per-axis units, pulse scaling and limits, and its closed-form
//! forward and inverse kinematics.
//!
//! Everything here is plain data and arithmetic: no threads, no I/O, and no heap allocation
//! after a [`Robot`] is built, so kinematics can run inside a real-time cycle.
//!
//! ```
//! use wrc_robot::{Posture, Pose, Robot};
//!
//! let robot = Robot::paper_default();
//! let pose = Pose { x: 250.0, y: 100.0, z: 20.0, yaw: 30.0 };
//! let joints = robot.inverse(&pose, Posture::Right, None).unwrap();
//! let back = robot.forward(&joints);
//! assert!((back.x - pose.x).abs() < 1e-9 && (back.y - pose.y).abs() < 1e-9);
//! ```
#![deny(missing_docs)]

mod axis;
mod error;
mod jet;
mod kinematics;
mod num;
mod robot;
pub mod shape;
pub mod solid;

pub use axis::{Axis, AxisName, AxisRole, InlineName, Limits, Unit};
pub use error::{KinematicsError, ModelError};
pub use jet::Jet;
pub use kinematics::{wrap180, IkCheck, JointJets, Pose, PoseJet, Posture};
pub use num::Num;
pub use robot::{Arm, Joints, Robot, MAX_AXES};
pub use shape::{ArmBodies, ArmShape, BladeLoad, BodyKind};
