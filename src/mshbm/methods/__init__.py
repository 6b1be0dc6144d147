"""The periodic-solution methods: each builds a problem object that satisfies the contract of :mod:`mshbm.methods.base`."""
