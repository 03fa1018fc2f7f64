//! Angles, wrapped once for everyone: the world's kinematics and every behaviour use this.

use std::f64::consts::PI;

/// Wraps an angle into (-pi, pi].
pub fn wrap_angle(a: f64) -> f64 {
    // `%` returns an angle already within one turn as it is, exactly: skipping it there (a
    // bearing almost always is) gives the same bits without the slow `fmod`.
    let mut a = if a.abs() < 2.0 * PI {
        a
    } else {
        a % (2.0 * PI)
    };
    if a <= -PI {
        a += 2.0 * PI;
    } else if a > PI {
        a -= 2.0 * PI;
    }
    a
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The fast path must give the bits the plain `%` gives, at the edges of a turn too.
    #[test]
    fn skipping_the_remainder_within_a_turn_changes_no_bit() {
        let reference = |a: f64| {
            let mut a = a % (2.0 * PI);
            if a <= -PI {
                a += 2.0 * PI;
            } else if a > PI {
                a -= 2.0 * PI;
            }
            a
        };
        let tau = 2.0 * PI;
        let mut cases = vec![
            0.0,
            -0.0,
            PI,
            -PI,
            tau,
            -tau,
            f64::NAN,
            f64::INFINITY,
            1e300,
            -1e-300,
        ];
        for edge in [PI, tau, 3.0 * PI] {
            for k in 0..4 {
                let near = f64::from_bits(edge.to_bits() - 2 + k);
                cases.extend([near, -near]);
            }
        }
        let mut seed = 5u64;
        for _ in 0..100_000 {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            cases.push(((seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * 30.0);
        }
        for a in cases {
            assert_eq!(wrap_angle(a).to_bits(), reference(a).to_bits(), "{a:e}");
        }
    }
}
