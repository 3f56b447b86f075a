"""The scene: the mic pair's geometry, the sensor model, free-field propagation and fractional
delays, noise fields, mixing at an SNR, and composing a scene's images.  Uses the room engine
(scenesim.room) for reverberant scenes; the room engine never imports the scene."""
