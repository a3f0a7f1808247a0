"""Operator control of motion: the latched software stop, the tool policy, approvals."""
