//! The start-up report of a compiled map: where every scorer input comes from, or that it is
//! derived or defaulted, one line each.
use super::compiled::{CompiledMap, EgoField, Mount, PartnerField, EGO_NAMES};
use super::file::{MissingVelocity, PositionKind, VelocityFrame};

impl CompiledMap {
    /// One line per scorer input: where it comes from, or that it is derived or defaulted.
    /// Printed at start-up so a vehicle engineer sees what the bridge assumes.
    pub fn input_report(&self) -> Vec<String> {
        let mut lines = Vec::new();
        let has = |f: PartnerField| self.has_partner_field[f as usize];
        let src = |f: PartnerField| self.partner_source[f as usize].clone();
        for (i, name) in EGO_NAMES.iter().enumerate() {
            let line = if self.has_ego_field[i] {
                format!("{name} <- {}", self.ego_source[i])
            } else {
                match i {
                    1 => format!("{name}: DEFAULT 0 m/s (not mapped)"),
                    2 => format!("{name}: DEFAULT 0 m/s^2 (not mapped)"),
                    3 if self.has_ego_field[EgoField::Heading as usize] => format!(
                        "{name}: DERIVED from the change of ego.heading over {} ms",
                        self.motion_window_us / 1000
                    ),
                    3 => format!(
                        "{name}: not mapped (a derived object velocity is not yaw-compensated)"
                    ),
                    4 => format!("{name}: DEFAULT {} m (not mapped)", self.ego_defaults.0),
                    5 => format!("{name}: DEFAULT {} m (not mapped)", self.ego_defaults.1),
                    _ => format!("{name}: not mapped"),
                }
            };
            lines.push(line);
        }
        let m = self.mount;
        if m != (Mount {
            x: 0.0,
            y: 0.0,
            cos: 1.0,
            sin: 0.0,
        }) {
            lines.push(format!(
                "sensor mounted at x {} m, y {} m, yaw {:.3} deg from the ego reference point",
                m.x,
                m.y,
                libm::atan2(m.sin, m.cos).to_degrees()
            ));
        }
        if self.slots > 0 {
            let companions = self.inputs.iter().filter(|m| m.companion).count();
            lines.push(format!(
                "objects: {} slot messages, one track per slot{}",
                self.slots,
                if companions > 0 {
                    format!(", {companions} companion messages joined by slot")
                } else {
                    String::new()
                }
            ));
        }
        let fov = self.fov;
        if fov.half_angle.is_some() || fov.max_range.is_some() {
            lines.push(format!(
                "field of view: {} wide, {}; a track outside is not scored and is dropped",
                fov.half_angle.map_or("any angle".into(), |h| format!(
                    "{:.1} deg",
                    (2.0 * h).to_degrees()
                )),
                fov.max_range
                    .map_or("any range".into(), |r| format!("up to {r} m"))
            ));
        }
        for (i, bus) in self.buses.iter().enumerate() {
            let n = self
                .inputs
                .iter()
                .filter(|m| m.bus == Some(i as u8))
                .count();
            lines.push(format!("bus {bus}: {n} input messages bound to it"));
        }
        match self.position {
            PositionKind::Cartesian => {
                lines.push(format!("object.pos_x <- {}", src(PartnerField::PosX)));
                lines.push(format!("object.pos_y <- {}", src(PartnerField::PosY)));
            }
            PositionKind::Polar => {
                lines.push(format!("object.range <- {}", src(PartnerField::Range)));
                lines.push(format!("object.azimuth <- {}", src(PartnerField::Azimuth)));
            }
        }
        let derived = match self.missing_velocity {
            Some(MissingVelocity::TrackMotion) => format!(
                "DERIVED from the track's motion over {} ms (a new track is scored once it has moved that long)",
                self.motion_window_us / 1000
            ),
            _ => "DEFAULT 0 m/s".to_string(),
        };
        let yaw_known = self.has_ego_field[EgoField::YawRate as usize]
            || self.has_ego_field[EgoField::Heading as usize];
        let derived = if self.missing_velocity == Some(MissingVelocity::TrackMotion) && yaw_known {
            format!("{derived}, compensated for the ego's yaw rate")
        } else {
            derived
        };
        if has(PartnerField::RangeRate) {
            lines.push(format!(
                "object radial velocity <- {}",
                src(PartnerField::RangeRate)
            ));
            if !(has(PartnerField::VelX) && has(PartnerField::VelY)) {
                lines.push(format!("object tangential velocity: {derived}"));
            }
        }
        for f in [PartnerField::VelX, PartnerField::VelY] {
            if has(f) {
                lines.push(format!("{} <- {}", f.name(), src(f)));
            } else if !has(PartnerField::RangeRate) {
                lines.push(format!("{}: {derived}", f.name()));
            }
        }
        lines.push(format!(
            "object velocities are {}",
            match self.velocity {
                VelocityFrame::Relative => "relative to the ego (ego velocity added)",
                VelocityFrame::Absolute => "over ground",
            }
        ));
        lines.push(if has(PartnerField::Heading) {
            format!("object.heading <- {}", src(PartnerField::Heading))
        } else {
            format!(
                "object.heading: DERIVED from the partner's velocity over ground (when faster than {} m/s), else its last heading, else +x",
                crate::engine::HEADING_FROM_VELOCITY_MIN_SPEED
            )
        });
        lines.push(if has(PartnerField::Accel) {
            format!(
                "object.accel <- {}{}",
                src(PartnerField::Accel),
                if self.accel_relative {
                    " (relative: the ego's accel is added)"
                } else {
                    ""
                }
            )
        } else {
            "object.accel: DEFAULT 0 m/s^2".to_string()
        });
        for (f, d) in [
            (PartnerField::Length, self.partner_defaults.0),
            (PartnerField::Width, self.partner_defaults.1),
        ] {
            lines.push(if has(f) {
                format!("{} <- {} (default {d} m until received)", f.name(), src(f))
            } else {
                format!("{}: DEFAULT {d} m (a car box)", f.name())
            });
        }
        lines.push(if has(PartnerField::Valid) {
            format!("object.valid <- {}", src(PartnerField::Valid))
        } else {
            "object.valid: not mapped (every object is valid)".to_string()
        });
        if has(PartnerField::NewTrack) {
            lines.push(format!(
                "object.new_track <- {} (a new object in a slot starts a fresh track)",
                src(PartnerField::NewTrack)
            ));
        }
        lines
    }
}
