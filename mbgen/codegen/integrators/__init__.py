"""codegen/integrators"""
