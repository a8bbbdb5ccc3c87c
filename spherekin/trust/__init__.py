"""The trust layer: polishing, the transversal system and its enclosures, the Krawczyk test, and the
resolution of clusters into solutions with statuses.
"""
