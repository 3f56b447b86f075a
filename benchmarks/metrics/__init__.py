"""Metrics: speech quality and intelligibility scores (PESQ, STOI, SI-SDR, SNRs), reverberation
metrics, SRMR, the distortion measures of the two Hagerman runs, and the evaluation of one
enhancer on one rendered condition.  Imports no run, store or report code."""
