"""The viewer's loop and everything it owns: settings (what the user asked for), state
(what the update derived), the update, playback, input, picking, camera, scripts,
stats, captures, the session and the engine warm-up."""
