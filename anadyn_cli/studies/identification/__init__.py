"""Dynamic parameter identification: the regressor (``regressor``), the base
parameters (``base``), the estimate from measured data (``estimate``) and the
exciting trajectory (``excite``)."""
