"""The validation report: the papers' findings reproduced with navbank's own simulator and FSW
(``navbank validation``; the narrative and tables end up in docs/validation.md)."""
