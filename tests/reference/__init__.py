"""Frozen reference implementations the tests check maniplab's compiled code against."""
