"""Readers and writers for the formats people have (MOTChallenge, KITTI tracking)."""
