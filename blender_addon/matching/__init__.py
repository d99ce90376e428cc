"""A photo in, parameters out: the reference read, the encoder and its fits, the estimate applied (`vto match`, `vto batch`)."""
