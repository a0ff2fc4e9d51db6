//! How large a room is: the floor its type plausibly has, fitted to what stands in it. A
//! study is not a 10 × 8 m hall; a room about three times its furniture's footprint and 4 m² more leaves
//! space to walk (and for a robot's camera to pass) without the bare floor and walls of a
//! room four or five times it.

use osmab_evaluator::synthetic::Rng;

/// The floor of one room type: the shortest and longest side it plausibly has, metres.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RoomSize {
    pub min_side: f64,
    pub max_side: f64,
}

/// Floor area per square metre of furniture footprint, before the type's bounds.
const AREA_PER_FOOTPRINT: f64 = 3.0;
/// Floor area every room has beyond that: a door to open, a path to walk.
const AREA_TO_WALK: f64 = 4.0;

/// The plausible floor of a room of type `room` (the spec's words, "bedroom", "meeting
/// room"); rooms the table does not know get the widest bounds.
pub fn size_of(room: &str) -> RoomSize {
    let (min_side, max_side) = match room {
        "bedroom" => (3.0, 4.8),
        "study" | "office" => (2.8, 4.6),
        "laundry room" => (2.6, 4.0),
        "kitchen" => (3.0, 5.4),
        "dining room" => (3.2, 5.6),
        "living room" | "reception area" => (3.6, 6.2),
        "meeting room" | "conference room" => (3.6, 7.0),
        "workshop" | "garage" => (3.2, 6.0),
        _ => (2.8, 6.5),
    };
    RoomSize { min_side, max_side }
}

/// The width and depth of a room of type `room` whose furniture covers `footprint` m²,
/// drawn from `rng` (its aspect), to the decimetre.
pub fn fitted_floor(room: &str, footprint: f64, rng: &mut Rng) -> (f64, f64) {
    let size = size_of(room);
    let area = (footprint * AREA_PER_FOOTPRINT + AREA_TO_WALK).clamp(size.min_side * size.min_side, size.max_side * size.max_side);
    let aspect = rng.range(0.8, 1.3);
    let side = |v: f64| ((v * 10.0).round() / 10.0).clamp(size.min_side, size.max_side);
    (side((area * aspect).sqrt()), side((area / aspect).sqrt()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_study_stays_a_study_and_a_meeting_room_grows_with_its_table() {
        let mut rng = Rng::new(1);
        let (w, d) = fitted_floor("study", 2.5, &mut rng);
        assert!(w <= 4.6 && d <= 4.6 && w * d < 16.0, "{w} × {d}");
        let (w, d) = fitted_floor("meeting room", 9.0, &mut rng);
        assert!(w * d > 20.0 && w >= 3.6 && d >= 3.6, "{w} × {d}");
        let (w, d) = fitted_floor("bedroom", 0.5, &mut rng);
        assert!(w >= 3.0 && d >= 3.0, "never below the type's shortest side: {w} × {d}");
    }
}
