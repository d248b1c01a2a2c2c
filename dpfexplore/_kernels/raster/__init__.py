"""The explorer's map: tips binned into pixels (:mod:`.binning`), arrays in, arrays out."""
