"""Vision: the framegrabber's pixels (digitiser, packing), the pinhole camera, the tool marker."""
