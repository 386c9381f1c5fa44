//! The console's side that is not HTTP: the [`hub::Hub`] where the pages' commands and the
//! robot's stream meet, the [`relay`] that owns the robot link (an operator session) and turns
//! telemetry into the pages' JSON, the recording and the Foxglove stream
//! ([`foxglove_hub`]), the map the pages draw ([`map_view`]). The web server (the page, its WebSocket, the access rules) is the front
//! end's (`omnikin console`).

pub mod foxglove_hub;
pub mod hub;
pub mod map_view;
pub mod relay;
