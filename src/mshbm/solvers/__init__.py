"""Solvers acting on any problem object: Newton, start ladder, continuation."""
