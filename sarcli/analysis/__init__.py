"""Accuracy analysis: the paper's point-spread-function kernel (:mod:`.psf`), impulse-response
measurement (:mod:`.ipr`), image quality against prediction (:mod:`.quality`) and error against
run time (:mod:`.benchmark`)."""
