//! The map file's rules (each error names its line) and the route on maps whose shortest path
//! is known in closed form.

use super::route::shortest_route;
use super::*;

fn err(text: &str) -> MapError {
    Map::from_toml(text, "m.toml").expect_err("the map must be refused")
}

#[test]
fn a_valid_map_keeps_its_shapes_and_lines() {
    let m = Map::from_toml(
        "# demo\n[[keep_out]]\ncircle = [1.0, 0.5, 0.2]\n\n[[keep_out]]\npolygon = [[2, 0], [3, 0], [3, 1]]\n[keep_in]\npolygon = [[-5, -5], [5, -5], [5, 5], [-5, 5], [-5, -5]]\n",
        "m.toml",
    )
    .unwrap();
    assert_eq!(m.keep_out.len(), 2);
    assert_eq!(m.keep_out[0].line, 3);
    assert_eq!(m.keep_out[1].line, 6);
    assert_eq!(m.keep_in.as_ref().unwrap().line, 8);
    // The closing vertex is dropped.
    let Shape::Polygon(v) = &m.keep_in.as_ref().unwrap().shape else {
        panic!()
    };
    assert_eq!(v.len(), 4);
}

#[test]
fn bad_maps_name_the_line_and_the_rule() {
    let cases: [(&str, usize, &str); 9] = [
        ("[[keep_out]]\ncircle = [1, 2, -0.5]\n", 2, "must be > 0"),
        ("[[keep_out]]\n\ncircle = [1, 2]\n", 3, "[x, y, radius]"),
        (
            "[[keep_out]]\npolygon = [[0, 0], [1, 1], [1, 0], [0, 1]]\n",
            2,
            "self-intersecting",
        ),
        (
            "[[keep_out]]\npolygon = [[0, 0], [1, 0], [2, 0]]\n",
            2,
            "collinear",
        ),
        (
            "[[keep_out]]\npolygon = [[0, 0], [1, 0]]\n",
            2,
            "at least 3",
        ),
        (
            "[[keep_out]]\npolygon = [[0, 0], [0, 1], [1, 0]]\n",
            2,
            "clockwise",
        ),
        (
            "[[keep_out]]\ncircle = [1500, 200, 300]\n",
            2,
            "millimetres",
        ),
        (
            "[[keep_out]]\ncircle = [1, 2, 0.3]\npolygon = [[0, 0], [1, 0], [1, 1]]\n",
            1,
            "both",
        ),
        (
            "[keep_in]\npolygon = [[0, 0], [1, 0], [1, 1]]\nradius = 2\n",
            3,
            "unknown field",
        ),
    ];
    for (text, line, rule) in cases {
        let e = err(text);
        assert_eq!(e.line, Some(line), "{text}: {e}");
        assert!(e.to_string().contains(rule), "{text}: {e}");
        assert!(
            e.to_string().starts_with(&format!("m.toml:{line}: ")),
            "{e}"
        );
    }
}

#[test]
fn a_start_inside_an_obstacle_or_outside_the_keep_in_is_refused_with_its_line() {
    let m = Map::from_toml(
        "[[keep_out]]\ncircle = [0, 0, 0.5]\n[keep_in]\npolygon = [[-3, -3], [3, -3], [3, 3], [-3, 3]]\n",
        "m.toml",
    )
    .unwrap();
    let e = shortest_route(&m, 0.1, [0.1, 0.0], [2.0, 2.0]).unwrap_err();
    assert_eq!(e.line, Some(2));
    assert!(
        e.message.contains("start") && e.message.contains("inside"),
        "{e}"
    );
    let e = shortest_route(&m, 0.1, [0.55, 0.0], [2.0, 2.0]).unwrap_err();
    assert!(e.message.contains("overlaps"), "{e}");
    let e = shortest_route(&m, 0.1, [-2.0, -2.0], [4.0, 0.0]).unwrap_err();
    assert_eq!(e.line, Some(4));
    assert!(
        e.message.contains("goal") && e.message.contains("outside the keep_in"),
        "{e}"
    );
}

#[test]
fn around_one_circle_the_route_is_two_tangents_and_an_arc() {
    // From (−d, 0) to (d, 0) around a circle of radius r at the origin, footprint f:
    // R = r + f, length = 2 sqrt(d² − R²) + R (π − 2 acos(R/d)).
    let (d, r, f) = (2.0, 0.4, 0.1);
    let m = Map::from_toml("[[keep_out]]\ncircle = [0, 0, 0.4]\n", "m.toml").unwrap();
    let route = shortest_route(&m, f, [-d, 0.0], [d, 0.0]).unwrap();
    let big_r: f64 = r + f;
    let exact = 2.0 * (d * d - big_r * big_r).sqrt()
        + big_r * (std::f64::consts::PI - 2.0 * (big_r / d).acos());
    assert!(
        route.length >= exact * (1.0 - 1e-9),
        "{} < {exact}",
        route.length
    );
    assert!(route.length <= exact * 1.001, "{} vs {exact}", route.length);
    for w in route.points.windows(2) {
        assert!(m.segment_clearance(w[0], w[1]) >= f * (1.0 - 1e-9));
    }
}

#[test]
fn a_goal_walled_in_is_unreachable_and_the_walls_are_named() {
    // Four boxes around the goal leave gaps of 0.1 m, narrower than the 0.3 m footprint.
    let m = Map::from_toml(
        "[[keep_out]]\npolygon = [[-1, 0.55], [1, 0.55], [1, 1], [-1, 1]]\n\
         [[keep_out]]\npolygon = [[-1, -1], [1, -1], [1, -0.55], [-1, -0.55]]\n\
         [[keep_out]]\npolygon = [[-1, -0.5], [-0.55, -0.5], [-0.55, 0.5], [-1, 0.5]]\n\
         [[keep_out]]\npolygon = [[0.55, -0.5], [1, -0.5], [1, 0.5], [0.55, 0.5]]\n",
        "m.toml",
    )
    .unwrap();
    let e = shortest_route(&m, 0.15, [3.0, 0.0], [0.0, 0.0]).unwrap_err();
    assert!(e.message.contains("no collision-free path"), "{e}");
    assert!(e.message.contains("lines 2, 4, 6, 8"), "{e}");
    // With a small footprint the gaps are open.
    assert!(shortest_route(&m, 0.02, [3.0, 0.0], [0.0, 0.0]).is_ok());
}

#[test]
fn an_l_shaped_keep_in_is_turned_around_its_inner_corner() {
    // The only way from the lower arm to the upper arm bends at the reflex corner (1, 1): the
    // route is longer than the two straight legs through the corner itself (5.099 m) and
    // shorter than the clear legs through (0.8, 0.8) (5.433 m).
    let m = Map::from_toml(
        "[keep_in]\npolygon = [[0, 0], [4, 0], [4, 1], [1, 1], [1, 4], [0, 4]]\n",
        "m.toml",
    )
    .unwrap();
    let (s, g, f) = ([3.5, 0.5], [0.5, 3.5], 0.2);
    let route = shortest_route(&m, f, s, g).unwrap();
    let via = |p: [f64; 2]| geometry::dist(s, p) + geometry::dist(p, g);
    assert!(route.length > via([1.0, 1.0]), "{}", route.length);
    assert!(route.length < via([0.8, 0.8]), "{}", route.length);
    for w in route.points.windows(2) {
        assert!(m.segment_clearance(w[0], w[1]) >= f * (1.0 - 1e-9));
    }
    let smooth = smooth::smooth(&m, &route, f).unwrap();
    assert!(smooth.min_clearance >= f * (1.0 - 1e-9));
    assert!(smooth::path_clearance(&m, &smooth.path, f / 50.0) >= f * (1.0 - 1e-9));
}

/// Four boxes leaving 0.1 m gaps around the origin (see the test above).
const WALLED: &str = "[[keep_out]]\npolygon = [[-1, 0.55], [1, 0.55], [1, 1], [-1, 1]]\n\
     [[keep_out]]\npolygon = [[-1, -1], [1, -1], [1, -0.55], [-1, -0.55]]\n\
     [[keep_out]]\npolygon = [[-1, -0.5], [-0.55, -0.5], [-0.55, 0.5], [-1, 0.5]]\n\
     [[keep_out]]\npolygon = [[0.55, -0.5], [1, -0.5], [1, 0.5], [0.55, 0.5]]\n";

#[test]
fn the_unreachable_message_says_which_end_is_enclosed() {
    let m = Map::from_toml(WALLED, "m.toml").unwrap();
    let msg = |from, to| shortest_route(&m, 0.15, from, to).unwrap_err().message;
    assert!(msg([3.0, 0.0], [0.0, 0.0]).ends_with("the goal is enclosed"));
    assert!(msg([0.0, 0.0], [3.0, 0.0]).ends_with("the start is enclosed"));
    // A second walled box far away: both ends are in pockets.
    let two = format!(
        "{WALLED}{}",
        WALLED
            .replace("[-1,", "[9,")
            .replace("[1,", "[11,")
            .replace("[-0.55,", "[9.45,")
            .replace("[0.55,", "[10.55,")
    );
    let m2 = Map::from_toml(&two, "m2.toml").unwrap();
    let e = shortest_route(&m2, 0.15, [0.0, 0.0], [10.0, 0.0]).unwrap_err();
    assert!(
        e.message
            .ends_with("the start and the goal are each enclosed"),
        "{e}"
    );
    // Inside a keep-in square the smaller region is the enclosed one.
    let kept = format!("{WALLED}[keep_in]\npolygon = [[-5, -5], [5, -5], [5, 5], [-5, 5]]\n");
    let m3 = Map::from_toml(&kept, "m3.toml").unwrap();
    let e = shortest_route(&m3, 0.15, [3.0, 0.0], [0.0, 0.0]).unwrap_err();
    assert!(e.message.ends_with("the goal is enclosed"), "{e}");
    let e = shortest_route(&m3, 0.15, [0.0, 0.0], [3.0, 0.0]).unwrap_err();
    assert!(e.message.ends_with("the start is enclosed"), "{e}");
}
