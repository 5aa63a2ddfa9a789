//! Acceleration from a smoothed speed, for recordings whose acceleration is tracking noise.
//!
//! Video-tracked trajectories (NGSIM) carry an acceleration that is close to a raw finite
//! difference of a jittery speed: calm driving then breaks the safe-sequence rule
//! (|acc| <= 1.5 m/s^2) on isolated frames. Replacing it by the derivative of a centred moving
//! average of the speed keeps real, sustained accelerations (pulling away from a red light) and
//! removes the single-frame spikes. Off by default: the recorded value is used as it is.

use super::derivative::speed_derivative;
use super::xml::Track;

/// Replaces every state's acceleration of `track` by the time derivative of its speed averaged
/// over a centred window of `window` seconds (`dt` s per step).
///
/// The average at a state takes every state of the track within `window / 2` seconds of it (by
/// time step, so missing steps do not stretch the window; near the ends of the track the window
/// is cut short). The derivative is the central difference of the averaged speed between the
/// neighbouring states (one-sided at the ends). A track of one state keeps its acceleration.
pub fn smooth_acceleration(track: &mut Track, window: f64, dt: f64) {
    let states = &mut track.states;
    let n = states.len();
    if n < 2 || window <= 0.0 {
        return;
    }
    let half_steps = (window / 2.0 / dt + 1e-9).floor() as i64;
    let mut averaged = Vec::with_capacity(n);
    let (mut lo, mut hi, mut sum) = (0usize, 0usize, 0.0f64);
    for i in 0..n {
        let step = states[i].step;
        while hi < n && states[hi].step <= step + half_steps {
            sum += states[hi].speed;
            hi += 1;
        }
        while states[lo].step < step - half_steps {
            sum -= states[lo].speed;
            lo += 1;
        }
        averaged.push(sum / (hi - lo) as f64);
    }
    for i in 0..n {
        states[i].acc = speed_derivative(n, i, dt, |k| (states[k].step, averaged[k]));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::import::commonroad::TrackState;

    fn track(speeds: &[(i64, f64)]) -> Track {
        Track {
            id: "1".into(),
            kind: "car".into(),
            length: 4.5,
            width: 1.8,
            states: speeds
                .iter()
                .map(|&(step, speed)| TrackState {
                    step,
                    x: 0.0,
                    y: 0.0,
                    orientation: 0.0,
                    speed,
                    acc: 99.0,
                })
                .collect(),
        }
    }

    #[test]
    fn a_steady_acceleration_is_kept_and_a_one_frame_spike_is_spread() {
        // 5 + 1.0 t at 0.1 s: a linear speed stays linear under a centred average.
        let mut steady = track(
            &(0..30)
                .map(|i| (i, 5.0 + 0.1 * i as f64))
                .collect::<Vec<_>>(),
        );
        smooth_acceleration(&mut steady, 1.0, 0.1);
        // Away from the ends, where the window is whole for both neighbours.
        for s in &steady.states[6..24] {
            assert!((s.acc - 1.0).abs() < 1e-9, "{s:?}");
        }
        // One frame 0.5 m/s off (raw differences +-5 m/s^2) at step 15.
        let mut spike = track(
            &(0..30)
                .map(|i| (i, if i == 15 { 10.5 } else { 10.0 }))
                .collect::<Vec<_>>(),
        );
        smooth_acceleration(&mut spike, 1.0, 0.1);
        let peak = spike.states.iter().map(|s| s.acc.abs()).fold(0.0, f64::max);
        // 11-state window: 0.5 / 11 m/s over 0.2 s, about 0.23 m/s^2.
        assert!((peak - 0.5 / 11.0 / 0.2).abs() < 1e-9, "{peak}");
    }

    #[test]
    fn missing_steps_do_not_widen_the_window() {
        let mut t = track(&[(0, 0.0), (1, 0.0), (40, 4.0), (41, 4.0)]);
        smooth_acceleration(&mut t, 1.0, 0.1);
        // Steps 0 and 1 average only each other (0 m/s), steps 40 and 41 only each other (4 m/s).
        let acc: Vec<f64> = t.states.iter().map(|s| s.acc).collect();
        assert_eq!(acc[0], 0.0, "{acc:?}");
        assert_eq!(acc[3], 0.0, "{acc:?}");
        // Step 1's neighbours are steps 0 and 40, 4 s apart.
        assert!((acc[1] - 4.0 / 4.0).abs() < 1e-9, "{acc:?}");
    }

    #[test]
    fn zero_window_keeps_the_recorded_acceleration() {
        let mut t = track(&[(0, 1.0), (1, 2.0)]);
        smooth_acceleration(&mut t, 0.0, 0.1);
        assert_eq!(t.states[0].acc, 99.0);
    }
}
