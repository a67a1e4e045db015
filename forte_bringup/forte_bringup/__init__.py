"""FORTE launch files (hardware, simulation, bag replay), parameter files, bag recording, the demo and the evaluation harness."""
