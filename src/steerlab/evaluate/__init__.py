"""Metrics, leaderboard scoring, plots and reports."""
