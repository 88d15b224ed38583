"""CPPN-NEAT designer: CPPNs paint bodies, neat-python evolves the CPPNs."""

from .designer import CppnNeat

__all__ = ["CppnNeat"]
