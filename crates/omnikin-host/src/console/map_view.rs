//! A map as the console's pages draw it: the sticky `map` message.

use omnikin_plan::map::{Map, Shape};
use serde_json::{Value, json};

/// The page message of `map` (world frame, m): `{"type": "map", "name", "keep_out": [{"circle":
/// [x, y, r]} | {"polygon": [[x, y], …]}], "keep_in": [[x, y], …] | null}`.
pub fn map_message(map: &Map) -> Value {
    let shape = |s: &Shape| match s {
        Shape::Circle { centre, radius } => json!({"circle": [centre[0], centre[1], radius]}),
        Shape::Polygon(v) => json!({"polygon": v}),
    };
    let keep_in = map.keep_in.as_ref().and_then(|o| match &o.shape {
        Shape::Polygon(v) => Some(json!(v)),
        Shape::Circle { .. } => None,
    });
    json!({
        "type": "map",
        "name": map.source_name,
        "keep_out": map.keep_out.iter().map(|o| shape(&o.shape)).collect::<Vec<_>>(),
        "keep_in": keep_in,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shapes_and_the_boundary_in_world_metres() {
        let m = Map::from_toml(
            "[[keep_out]]\ncircle = [1.0, 2.0, 0.5]\n[[keep_out]]\npolygon = [[0, 0], [1, 0], [0, 1]]\n[keep_in]\npolygon = [[-5, -5], [5, -5], [5, 5], [-5, 5]]\n",
            "m.toml",
        )
        .unwrap();
        let v = map_message(&m);
        assert_eq!(v["type"], "map");
        assert_eq!(v["keep_out"][0]["circle"], json!([1.0, 2.0, 0.5]));
        assert_eq!(v["keep_out"][1]["polygon"][2], json!([0.0, 1.0]));
        assert_eq!(v["keep_in"][3], json!([-5.0, 5.0]));
    }
}
