"""Mitsuba renders: the paper's bunny/armadillo figure (mitsuba) and the artist's check on real photos (artist_check)."""
