"""The glove's physics, from the paper and beyond it (docs/spec/model.md Parts I-III).

The parameters (:mod:`.params`), the Yeoh material, the cross-section and its pressure and
structural torques, the patient's finger, the coupled quasi-static solve and its inverse
(:mod:`.model`, :mod:`.solver`, :mod:`.inverse`), the contact-force estimators, the patient's
stiffness fit (:mod:`.identification`), the air of each chamber (:mod:`.pneumatics`), what the
model is validated for (:mod:`.validity`) and populations of patients (:mod:`.populations`).
No time here: :mod:`exodigit_model.stepping` advances a glove in time on top of it.
"""
