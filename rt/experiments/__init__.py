"""Experiments on the loop: step-sine FRFs, the paper's reproduction and claims, gain tuning, law comparison."""
