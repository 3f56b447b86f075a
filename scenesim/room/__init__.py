"""The room-acoustics engine: shoebox rooms, the image-source method (full, per band, hybrid),
air absorption and directivity, RT60 tools and calibration, moving sources, the RIR cache and
the pyroomacoustics cross-checks.  Imports only scenesim's core modules (errors, validate, files,
memo, audio), never the scene package."""
