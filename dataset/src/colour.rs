//! Colour names: what the questions call the colour of what the camera saw, and what a
//! finish of the class table is called.

/// The name of an sRGB colour, or `None` when it sits between names.
pub fn colour_name(rgb: [f64; 3]) -> Option<&'static str> {
    let [r, g, b] = rgb.map(|c| c / 255.0);
    let max = r.max(g).max(b);
    let min = r.min(g).min(b);
    let (value, chroma) = (max, max - min);
    let saturation = if max > 0.0 { chroma / max } else { 0.0 };
    if value < 0.18 {
        return Some("black");
    }
    if saturation < 0.12 {
        return Some(if value > 0.82 {
            "white"
        } else if value > 0.3 {
            "grey"
        } else {
            "black"
        });
    }
    if saturation < 0.2 {
        return None;
    }
    let hue = if chroma == 0.0 {
        0.0
    } else if max == r {
        60.0 * ((g - b) / chroma).rem_euclid(6.0)
    } else if max == g {
        60.0 * ((b - r) / chroma + 2.0)
    } else {
        60.0 * ((r - g) / chroma + 4.0)
    };
    Some(match hue {
        h if !(12.0..345.0).contains(&h) => "red",
        // Wood, leather, terracotta, cardboard: brown unless vivid; pale tan is beige,
        // which has no name here.
        h if h < 45.0 => {
            if saturation >= 0.55 && value >= 0.65 {
                "orange"
            } else if value >= 0.8 && saturation < 0.3 {
                return None;
            } else {
                "brown"
            }
        }
        h if h < 70.0 => "yellow",
        h if h < 165.0 => "green",
        h if h < 255.0 => "blue",
        h if h < 290.0 => "purple",
        _ => "pink",
    })
}
