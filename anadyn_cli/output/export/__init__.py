"""Standalone code and documents from the equations of motion (``anadyn export``).

``model.ExportModel`` holds what every language needs; ``c``, ``python``,
``matlab`` and ``latex`` print it.  Nothing generated imports anadyn.
"""
