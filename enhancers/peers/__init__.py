"""Peers run as black boxes or thin wrappers: the framed black-box base and resampling
(``blackbox``), DeepFilterNet3 (``dfn3``), RNNoise (``rnnoise``), WebRTC NS (``webrtc_ns``) and WPE
dereverberation (``wpe``). Each imports its optional package only when it is used."""
