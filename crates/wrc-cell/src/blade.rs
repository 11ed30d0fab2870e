//! The robot's blades: a single-hand robot has blade `A`; a dual-blade robot carries a second
//! blade `B` on the same wrist, stacked under (or over) `A` at a fixed height offset and
//! pointing the same way, so that it can take a processed wafer and put a new one at a
//! process module without leaving it (`SWAP`).

use std::fmt;

/// Most blades a robot carries.
pub const MAX_BLADES: usize = 2;

/// One of the robot's blades.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, PartialOrd, Ord)]
pub enum Blade {
    /// The robot's hand (the upper blade of a dual-blade robot): the TCP is its wafer centre.
    #[default]
    A,
    /// The second blade of a dual-blade robot.
    B,
}

impl Blade {
    /// Both blades, `A` first.
    pub const ALL: [Blade; MAX_BLADES] = [Blade::A, Blade::B];

    /// 0 for `A`, 1 for `B`.
    pub fn index(self) -> usize {
        match self {
            Blade::A => 0,
            Blade::B => 1,
        }
    }

    /// `A` or `B`.
    pub fn as_str(self) -> &'static str {
        match self {
            Blade::A => "A",
            Blade::B => "B",
        }
    }

    /// `A` or `B`, in either case.
    pub fn parse(text: &str) -> Option<Blade> {
        match text {
            "A" | "a" => Some(Blade::A),
            "B" | "b" => Some(Blade::B),
            _ => None,
        }
    }

    /// The other blade.
    pub fn other(self) -> Blade {
        match self {
            Blade::A => Blade::B,
            Blade::B => Blade::A,
        }
    }
}

impl fmt::Display for Blade {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}
