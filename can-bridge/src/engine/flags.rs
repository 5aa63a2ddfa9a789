//! Which scorer inputs of a track update were not sent by the sensor but derived or defaulted:
//! what `decode` writes beside each state, so a user sees how much of the state is guessed.

/// A set of [`InputFlags`] constants.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct InputFlags(pub u16);

impl InputFlags {
    /// The partner's longitudinal (or radial) speed comes from its position change.
    pub const VEL_LONG_DERIVED: u16 = 1 << 0;
    /// The partner's lateral (or tangential) speed comes from its position change.
    pub const VEL_LAT_DERIVED: u16 = 1 << 1;
    /// The partner's longitudinal relative speed is a default 0 (not sent, not derived).
    pub const VEL_LONG_DEFAULT: u16 = 1 << 2;
    /// The partner's lateral relative speed is a default 0 (not sent, not derived).
    pub const VEL_LAT_DEFAULT: u16 = 1 << 3;
    /// The partner's heading is the direction of its velocity.
    pub const HEADING_FROM_VELOCITY: u16 = 1 << 4;
    /// The partner's heading is held from its previous update (too slow to tell).
    pub const HEADING_HELD: u16 = 1 << 5;
    /// The partner's heading is the default +x.
    pub const HEADING_DEFAULT: u16 = 1 << 6;
    /// The partner's acceleration is a default 0.
    pub const ACCEL_DEFAULT: u16 = 1 << 7;
    /// The partner's length or width is the map's default.
    pub const SIZE_DEFAULT: u16 = 1 << 8;
    /// The ego's lateral speed is a default 0.
    pub const EGO_VEL_LAT_DEFAULT: u16 = 1 << 9;
    /// The ego's acceleration is a default 0.
    pub const EGO_ACCEL_DEFAULT: u16 = 1 << 10;
    /// The ego's length or width is the map's default.
    pub const EGO_SIZE_DEFAULT: u16 = 1 << 11;

    /// Every flag with its column name, in column order.
    pub const NAMES: [(u16, &'static str); 12] = [
        (Self::VEL_LONG_DERIVED, "vx_derived"),
        (Self::VEL_LAT_DERIVED, "vy_derived"),
        (Self::VEL_LONG_DEFAULT, "vx_default"),
        (Self::VEL_LAT_DEFAULT, "vy_default"),
        (Self::HEADING_FROM_VELOCITY, "heading_from_velocity"),
        (Self::HEADING_HELD, "heading_held"),
        (Self::HEADING_DEFAULT, "heading_default"),
        (Self::ACCEL_DEFAULT, "accel_default"),
        (Self::SIZE_DEFAULT, "size_default"),
        (Self::EGO_VEL_LAT_DEFAULT, "ego_vy_default"),
        (Self::EGO_ACCEL_DEFAULT, "ego_accel_default"),
        (Self::EGO_SIZE_DEFAULT, "ego_size_default"),
    ];

    pub fn has(self, flag: u16) -> bool {
        self.0 & flag != 0
    }

    pub(super) fn set(&mut self, flag: u16, on: bool) {
        if on {
            self.0 |= flag;
        }
    }
}
