//! The soak and the cell: random motion targets that stand clear of it, and what the
//! simulated cell (the ground truth) counted. Every station is a solid the arm enters only
//! along its line ([`wrc_cell::obstacle`]): a target that puts the arm into one is refused
//! before anything moves (`NAK 117`), and a soak of mostly refused motions would hardly move
//! the robot. A target clear of the cell is reached by a joint move, straight or round
//! through the travel height (`ACK <id> route=travel`); a straight line to it may still
//! cross a station, and is refused with 117 then, as it must be.

use std::path::Path;

use anyhow::Context;
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use wrc_cell::{CellModel, LineTolerance, Stations, World};
use wrc_robot::{BladeLoad, Joints, Robot, MAX_AXES};

/// How many random joint vectors [`Targets::joints`] draws at most for one clear of the
/// cell (about every other one is, on the demo cell).
const TRIES: usize = 200;

/// Random joint targets within 90 % of each axis's range whose arm stands clear of the cell.
pub(super) struct Targets {
    robot: Robot,
    model: CellModel,
}

impl Targets {
    /// Targets for `robot` in the cell of the stations file `stations` (the one `wrc up`
    /// runs with).
    pub(super) fn new(robot: &Robot, stations: &Path) -> anyhow::Result<Targets> {
        let cell = || format!("the soak's cell, {}", stations.display());
        let model = Stations::load(stations)
            .with_context(cell)?
            .model(robot)
            .with_context(cell)?;
        Ok(Targets {
            robot: robot.clone(),
            model,
        })
    }

    /// A random joint vector within 90 % of each axis's range at which the arm, its hand
    /// empty, keeps the controller's clearance from every station and obstacle (after
    /// [`TRIES`] draws, the last one, whatever it touches).
    pub(super) fn joints(&self, rng: &mut ChaCha8Rng) -> Joints {
        let mut j: Joints = [0.0; MAX_AXES];
        for _ in 0..TRIES {
            for (v, a) in j.iter_mut().zip(self.robot.axes()) {
                *v = (a.min + a.max) / 2.0 + (rng.random::<f64>() - 0.5) * 0.9 * (a.max - a.min);
            }
            if self.clear(&j) {
                break;
            }
        }
        j
    }

    /// Whether the arm at `joints`, its hand empty, keeps the controller's clearance from
    /// every station (off its line) and obstacle.
    fn clear(&self, joints: &Joints) -> bool {
        let blades = [BladeLoad::default()];
        let bodies = self.robot.bodies(joints, &blades);
        let margin = self.model.settings().clearance_mm;
        self.model
            .contact(&bodies, &blades, &LineTolerance::CONTROLLER, margin)
            .is_none()
    }
}

/// The side collisions the simulated cell of state directory `state` counted (its world
/// file, read with its stations file), and the station or obstacle of the latest: a body of
/// the arm that touched a station off its line, or an obstacle. The board writes the file a
/// moment after each change and as it stops.
pub(super) fn side_collisions(state: &Path) -> anyhow::Result<(u32, Option<String>)> {
    let stations = Stations::load(&state.join("stations.toml"))
        .with_context(|| format!("the stations of {}", state.display()))?;
    let path = state.join("world.toml");
    let text = std::fs::read_to_string(&path)
        .with_context(|| format!("cannot read the simulated cell {}", path.display()))?;
    let world = World::from_text(&text, &stations)
        .with_context(|| format!("the simulated cell {}", path.display()))?;
    Ok((
        world.side_collisions(),
        world.last_side_collision().map(|n| n.to_string()),
    ))
}

#[cfg(test)]
mod tests {
    use rand::SeedableRng;
    use wrc_config::Config;

    use super::*;

    #[test]
    fn targets_on_the_demo_cell_are_clear_of_it_and_not_all_folded_or_low() {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("stations.toml");
        std::fs::write(&file, wrc_cell::DEMO_TOML).unwrap();
        let robot = Config::embedded_default().robot;
        let targets = Targets::new(&robot, &file).unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let (mut reach, mut high) = (0, 0);
        for _ in 0..200 {
            let j = targets.joints(&mut rng);
            assert!(targets.clear(&j), "{j:?}");
            let p = robot.forward(&j);
            reach += usize::from(p.x.hypot(p.y) > 300.0);
            high += usize::from(p.z > 50.0);
        }
        // The draws still cover the workspace: far out and high up.
        assert!(reach > 20 && high > 50, "{reach} far out, {high} high up");
        // And the check is not vacuous: a pose with the hand in LP2's side is not clear.
        let into_lp2 = robot
            .inverse(
                &wrc_robot::Pose {
                    x: 250.0,
                    y: 100.0,
                    z: 20.0,
                    yaw: 30.0,
                },
                wrc_robot::Posture::Right,
                None,
            )
            .unwrap();
        assert!(!targets.clear(&into_lp2));
    }
}
