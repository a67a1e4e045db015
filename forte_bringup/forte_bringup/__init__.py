"""FORTE bringup: launch files, parameter files, bag recording, demo, evaluation.
"""
